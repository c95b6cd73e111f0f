"""``ndrql reproduce release``: the release report, the only evaluation of the sealed sets.

The development sets (``transfer``, ``select``, ``tune``) were read while the model, the presets and
the baselines were chosen, so their figures are not held-out evidence. The sealed sets
(:mod:`ndrql.experiments.eval_sets`, seeds in :data:`~ndrql.limits.SEALED_SEEDS`) are read by this
command alone, after every choice of a release, with the transfer report's code
(:func:`ndrql.experiments.transfer.transfer`: the same rows, statistics and tables). Before it reads a
set it

1. checks that each map and problem matches the digests recorded when the set was drawn
   (:func:`~ndrql.experiments.eval_sets.verify_seal`),
2. refuses a working tree with uncommitted changes (the report names a commit that holds everything
   it ran; ``allow_dirty`` records ``-dirty`` instead),
3. appends a run to the ledger (a committed JSON file, written atomically) *before* evaluating: a run
   that is interrupted still counts, since its maps were read.

The report states how many times each sealed set has been evaluated and with which commits.
"""

from __future__ import annotations

import datetime as _dt
import gzip
import json
import subprocess
from pathlib import Path
from typing import Callable

from ndrql.errors import NdrqlError
from ndrql.experiments.eval_sets import eval_set, eval_spec, registry, verify_seal
from ndrql.experiments.transfer import transfer
from ndrql.experiments.transfer_report import rows_at
from ndrql.io import file_digest, write_bytes, write_json
from ndrql.planning.preset import Preset

#: The ledger's format tag.
LEDGER_FORMAT = "ndrql-release-ledger"
#: Where the ledger lives in a source checkout (relative to its root, the working directory of the command).
DEFAULT_LEDGER = Path("docs") / "release" / "ledger.json"


def git_commit(root: Path) -> tuple[str, bool]:
    """The commit checked out at ``root`` and whether the tree has uncommitted changes (``("unknown",
    False)`` outside a git checkout)."""
    try:
        sha = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                             check=True, timeout=30).stdout.strip()
        status = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                                capture_output=True, text=True, check=True, timeout=30).stdout
    except (OSError, subprocess.SubprocessError):
        return "unknown", False
    return sha, bool(status.strip())


def read_ledger(path: Path) -> dict:
    """The ledger at ``path`` (an empty one when the file does not exist yet)."""
    if not path.exists():
        return {"format": LEDGER_FORMAT, "version": 1, "runs": []}
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise NdrqlError(f"unreadable release ledger {path}: {type(exc).__name__}") from None
    if not isinstance(data, dict) or data.get("format") != LEDGER_FORMAT or not isinstance(data.get("runs"), list):
        raise NdrqlError(f"{path} is not a release ledger")
    return data


def default_release(names: list[str] | None, grids: tuple[int, ...] | None) -> tuple[list[str], tuple[int, ...]]:
    """The sets and grids of one release run: without names, the set ``sealed``; without grids, the grids
    the sets were drawn for (the registry's ``grids``), which must agree (a large set is released on its own)."""
    names = names or ["sealed"]
    if grids:
        return names, tuple(grids)
    sets = registry()
    own = {sets[n].grids for n in names}
    if len(own) > 1:
        raise NdrqlError(f"the sets {', '.join(names)} are drawn for different grids "
                         f"({'; '.join(f'{n}: {sets[n].grids}' for n in names)}): release them one at a time or give --grids")
    return names, own.pop()


def times_evaluated(ledger: dict, name: str) -> int:
    """How many runs of the ledger read the sealed set ``name``."""
    return sum(name in run["sets"] for run in ledger["runs"])


def keep_records(summary: Path, folder: Path, run_id: int, name: str) -> dict:
    """The per-map records of one sealed read, gzipped beside the ledger (``records/run-<id>-<set>.json.gz``, to be
    committed with it) so that a reader can recompute every table; their path and SHA-256 for the ledger."""
    if not summary.is_file():
        return {}
    target = folder / "records" / f"run-{run_id}-{name}.json.gz"
    write_bytes(target, gzip.compress(summary.read_bytes(), mtime=0))
    return {"records": target.as_posix(), "records_sha256": file_digest(target)}


def attempt_line(book: dict, grid: int, run_id: int, name: str | None = None) -> str:
    """``- grid N: sealed read k at this size (runs ...)``: how many runs of the ledger up to ``run_id`` read a sealed
    set (``name``: that set) at ``grid``, so that a held-out figure names its attempt."""
    runs = [r["run"] for r in book["runs"] if grid in r.get("grids", []) and r["run"] <= run_id
            and (name is None or name in r["sets"])]
    earlier = ", ".join(map(str, runs[:-1])) or "none"
    what = "sealed read" if name is None else f"read of {name}"
    return (f"- grid {grid}: {what} {len(runs)} at this size (earlier runs at this size: {earlier}; "
            f"what each showed: docs/results.md)\n")


def check_sealed_names(names: list[str]) -> list[str]:
    """``names`` if each is a registered sealed set; a development set is refused (its figures are the
    transfer report's)."""
    sets = registry()
    for name in names:
        if name not in sets:
            raise NdrqlError(f"unknown evaluation set {name!r}; sealed sets: "
                             f"{', '.join(n for n, s in sets.items() if s.role == 'sealed')}")
        if sets[name].role != "sealed":
            raise NdrqlError(f"{name!r} is a development set: the release report reads sealed sets only "
                             f"(run `ndrql reproduce transfer --eval-set {name}`)")
    if not names:
        raise NdrqlError("no sealed set given")
    return names


def release(out: str | Path, sets: list[str], *, ledger: str | Path = DEFAULT_LEDGER, repo: str | Path = ".",
            allow_dirty: bool = False, weights: str | None = None, preset: Preset | None = None,
            grids: tuple[int, ...] = (50, 100), seeds: int = 10, seed0: int = 0, workers: int = 2,
            executor: str = "process", progress: bool = True, command: str = "",
            log: Callable[[str], None] = print, rows: tuple[str, ...] | None = None) -> list[Path]:
    """Evaluate each sealed set of ``sets`` once (module docstring); one report per set under ``out/<set>/``.
    ``rows``: the report's rows (``None``: :func:`~ndrql.experiments.transfer_report.default_rows` per grid)."""
    names = check_sealed_names(list(dict.fromkeys(sets)))
    ledger = Path(ledger)
    book, entry = open_read(ledger, names, grids, repo=repo, allow_dirty=allow_dirty, progress=progress,
                            seeds=[seed0, seed0 + seeds - 1], rows={str(n): list(rows_at(n, rows)) for n in grids},
                            preset=preset.name if preset else "spec", command=command)
    run_id = entry["run"]
    paths = []
    for name in names:
        prior = [r["commit"] for r in book["runs"] if name in r["sets"]]
        header = (f"# Release report: sealed set {name!r}\n\nThis set has been evaluated {len(prior)} time"
                  f"{'s' if len(prior) != 1 else ''} (ledger {ledger.as_posix()}: runs with commits "
                  f"{', '.join(prior)}); this is run {run_id}, commit {entry['commit']}.\n\n"
                  + "".join(attempt_line(book, n, run_id) for n in grids) + "\n")
        path = transfer(Path(out) / name, weights=weights, set_name=name, grids=grids, seeds=seeds, seed0=seed0,
                        workers=workers, executor=executor, progress=progress, command=command, log=log,
                        preset=preset, release=True, header=header, name="release", rows=rows)
        entry["reports"][name] = {"path": path.as_posix(), "sha256": file_digest(path),
                                  **keep_records(path.parent / "summary.json", ledger.parent, run_id, name)}
        paths.append(path)
    close_read(ledger, book, entry)
    return paths


def open_read(ledger: Path, names: list[str], grids: tuple[int, ...] | list[int], *, repo: str | Path = ".",
              allow_dirty: bool = False, progress: bool = True, **fields: object) -> tuple[dict, dict]:
    """Steps 1-3 of the module docstring for the sealed sets ``names`` at ``grids``: the seal checked, a dirty tree
    refused, the run appended to the ledger (with ``fields``: seeds, rows, preset, command, ...) and written before a
    single map is read. Returns the ledger and the run's entry (``entry["run"]``: its number)."""
    if not ledger.parent.is_dir():
        raise NdrqlError(f"--ledger {ledger}: its folder does not exist (run from the source checkout, or give --ledger)")
    commit, dirty = git_commit(Path(repo))
    if dirty and not allow_dirty:
        raise NdrqlError("the working tree has uncommitted changes: commit them first, so that the report names "
                         "everything it ran (or --allow-dirty, recorded as such)")
    for name in names:  # every set matches its seal before any is evaluated
        verify_seal(name, eval_set(eval_spec(name, release=True), progress, release=True))
    book = read_ledger(ledger)
    entry = {"run": len(book["runs"]) + 1, "commit": commit + ("-dirty" if dirty else ""),
             "started": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"), "sets": list(names),
             "grids": list(grids), **fields, "finished": None, "reports": {}}
    book["runs"].append(entry)
    write_json(ledger, book)  # counted before a single map is read
    return book, entry


def close_read(ledger: Path, book: dict, entry: dict) -> None:
    """The run's end time in the ledger (its reports already in ``entry["reports"]``)."""
    entry["finished"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    write_json(ledger, book)
