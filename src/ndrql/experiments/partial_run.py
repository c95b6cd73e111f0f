"""``ndrql reproduce partial`` end to end: the tasks, the executor, the resumable records, the report and its figure.

The tasks (:class:`ndrql.experiments.partial.Task`: the truth's rows once per map and grid, the belief's rows per
setting and sensing) run through the one executor (:func:`ndrql.workers.run_calls`); each finished record is
appended to ``OUT/records.jsonl`` (:class:`~ndrql.io.jsonl.BatchLog`: a re-run resumes; records of other seeds,
weights or preset are refused with one line). The report ``OUT/partial.md`` (:mod:`ndrql.experiments.partial_report`)
and the figure ``OUT/partial_map.png`` (:func:`ndrql.viz.partial.belief_figure`) are written atomically.

A sealed set is read as ``reproduce release`` reads one (:func:`ndrql.experiments.release.open_read`): its seal
checked, a dirty tree refused, the read counted in the ledger before a single map is read, and the report names
the attempt; the records are kept gzipped beside the ledger.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ndrql.errors import FallbackWarning, NdrqlError
from ndrql.experiments import eval_sets
from ndrql.experiments.release import attempt_line, close_read, keep_records, open_read
from ndrql.experiments.partial import (DEFAULT_BELIEFS, FORMAT, REF, ROWS, BeliefSetting, Task, _generated,
                                       one_case, parse_beliefs, plan_request, run_task)
from ndrql.experiments.partial_report import FLOOR_SETTING, joined, report_text
from ndrql.io import file_digest, save_figure, write_text
from ndrql.io.jsonl import BatchLog
from ndrql.maps.grid import SnapWarning
from ndrql.model.weights import plan_weights, resolve_weights, weights_label
from ndrql.viz.partial import belief_figure
from ndrql.workers import pick_executor, run_calls

#: The report, its records and its figure under ``OUT``.
REPORT, RECORDS, FIGURE = "partial.md", "records.jsonl", "partial_map.png"


def belief_weights(weights: str | None) -> tuple[str, str]:
    """``(file, label)`` of the weights ``plan --hide`` uses with ``weights`` (``None``: what it picks by itself)."""
    path = resolve_weights(plan_weights(weights, partial=True))
    return str(path), weights_label(path)


def tasks_of(set_name: str, release: bool, count: int, grids: tuple[int, ...], settings: tuple[BeliefSetting, ...],
             senses: tuple[bool, ...], seeds: tuple[int, ...], preset: str, weights: str | None,
             runner: Callable[[Any], Any]) -> list[Task]:
    """Every task: per map and grid the truth's, then each setting with each sensing."""
    out = []
    for grid in grids:
        for i in range(count):
            out.append(Task(set_name, release, i, grid, seeds, preset))
            out += [Task(set_name, release, i, grid, seeds, preset, weights, s.label, sense, runner)
                    for s in settings for sense in senses]
    return out


def partial(out: str | Path, *, runner: Callable[[Any], Any], set_name: str = "partial-dev", grids: tuple[int, ...] = (50, 100),
            beliefs: str = DEFAULT_BELIEFS, senses: tuple[bool, ...] = (False, True), seeds: int = 10, seed0: int = 0,
            weights: str | None = None, preset: str = "general", workers: int = 2, executor: str = "process",
            limit: int | None = None, ledger: str | Path = "docs/release/ledger.json", allow_dirty: bool = False,
            repo: str | Path = ".", command: str = "", progress: bool = True, figure: bool = True,
            log: Callable[[str], None] = print) -> Path:
    """Measure (resuming), then write the report and the figure; returns the report's path (module docstring).
    ``runner``: what runs a plan's request, :func:`ndrql.api.run_request` (experiments sit below the API: the caller
    hands it down)."""
    settings = parse_beliefs(beliefs)
    sets = eval_sets.registry()  # looked up on the module: tests give it a registry of their own
    if set_name not in sets:
        raise NdrqlError(f"unknown evaluation set {set_name!r}; valid: {', '.join(sets)}")
    sealed = sets[set_name].role == "sealed"
    if sealed and limit is not None:
        raise NdrqlError("--limit does not apply to a sealed set: it is evaluated whole")
    wfile, wlabel = belief_weights(weights)
    out = Path(out)
    book = entry = None
    if sealed:
        book, entry = open_read(Path(ledger), [set_name], grids, repo=repo, allow_dirty=allow_dirty, progress=progress,
                                seeds=[seed0, seed0 + seeds - 1], rows={str(n): list(ROWS) for n in grids},
                                preset=preset, command=command, target="partial", beliefs=[s.label for s in settings],
                                sense=["on" if s else "off" for s in senses], weights=wlabel)
    gs = _generated(set_name, sealed)
    count = len(gs) if limit is None else min(limit, len(gs))
    seed_list = tuple(range(seed0, seed0 + seeds))
    tasks = tasks_of(set_name, sealed, count, tuple(grids), settings, tuple(senses), seed_list, preset, weights, runner)
    key = {"set": set_name, "seeds": list(seed_list), "preset": preset, "weights_sha256": file_digest(wfile)[:16]}
    records: dict[int, dict[str, Any]] = {}
    with BatchLog(out / RECORDS, FORMAT, key, "id") as blog:
        todo = [t for t in tasks if t.id not in blog.done]
        log(f"partial: {len(tasks) - len(todo)} of {len(tasks)} tasks done earlier; running {len(todo)} "
            f"({set_name}, grids {','.join(map(str, grids))}, {len(seed_list)} seeds, weights {wlabel})")

        def keep(i: int, rec: dict[str, Any]) -> None:
            blog.append({**key, **rec})
            records[rec["id"]] = rec
            if progress and (len(records) % 20 == 0 or len(records) == len(todo)):
                log(f"partial: {len(records)} / {len(todo)}")

        run_calls(run_task, [(t,) for t in todo], executor=pick_executor(executor, workers, len(todo)),
                  workers=workers, on_result=keep)
        done = {**blog.done, **records}
    recs = [done[t.id] for t in tasks if t.id in done]
    header = (f"# NDR-QL on maps the planner does not fully know (ndrql reproduce partial)\n\n"
              f"Set {set_name!r} ({sets[set_name].role}; {count} maps), grids {', '.join(map(str, grids))}, seeds "
              f"{seed0}..{seed0 + seeds - 1}, preset {preset}, NDR-QL's weights {wlabel}; every row a ratio to IQL-BFS "
              f"on the belief (geometric mean over maps of per-map mean steps). Command: `{command or '-'}`.\n\n")
    if entry is not None:
        header += (f"Ledger {Path(ledger).as_posix()}: run {entry['run']}, commit {entry['commit']}.\n\n"
                   + "".join(attempt_line(book, n, entry["run"], set_name) for n in grids) + "\n")
    if figure:
        pic = map_figure(out / FIGURE, gs, recs, tuple(grids), Task(set_name, sealed, 0, 0, (seed0,), preset, weights,
                                                                    runner=runner))
        header += f"Figure: {pic.name if pic else 'none (no map with every row)'}.\n\n"
    path = write_text(out / REPORT, report_text(recs, header, tuple(grids), [s.label for s in settings], tuple(senses)))
    if entry is not None:
        entry["reports"][set_name] = {"path": path.as_posix(), "sha256": file_digest(path),
                                      **keep_records(out / RECORDS, Path(ledger).parent, entry["run"], set_name)}
        close_read(Path(ledger), book, entry)
    return path


def _oracle_gain(rec: dict) -> float:
    """Oracle / IQL-BFS (belief), per-map mean steps, of a joined record (:func:`partial_report.joined`); ``inf``
    without both rows. The lower, the more knowing the hidden part is worth on this map."""
    rows = rec["rows"]
    if REF not in rows or "NDR-QL (oracle)" not in rows:
        return math.inf
    return float(np.mean(rows["NDR-QL (oracle)"]["steps"]) / max(1e-9, np.mean(rows[REF]["steps"])))


def _served(rec: dict) -> bool:
    ndr = rec.get("ndr") or {}
    return ndr.get("served") is not None and not ndr.get("fallback")


def figure_record(recs: list[dict], grids: tuple[int, ...]) -> dict | None:
    """The map the figure shows, picked from the records alone: of the reported setting (blobs 30% without sensing
    when measured, else the first setting without sensing, else any) at the first grid, among the maps where NDR-QL's
    priors were served (none: every map with NDR-QL's row), the one where the oracle's gain over IQL-BFS (belief) is
    largest (:func:`_oracle_gain` lowest; ties: the lowest index). The record has the truth's rows joined in."""
    cands = [r for r in joined(recs) if "NDR-QL" in r["rows"] and r["grid"] == grids[0]]
    floor = [r for r in cands if (r["belief"], r["sense"]) == FLOOR_SETTING]
    if not floor:
        first = next((r["belief"] for r in cands if not r["sense"]), None)
        floor = [r for r in cands if (r["belief"], r["sense"]) == (first, False)]
    cands = floor or cands
    pool = [r for r in cands if _served(r)] or cands
    return min(pool, key=lambda r: (_oracle_gain(r), r["index"]), default=None)


def map_figure(path: Path, gs: Any, recs: list[dict], grids: tuple[int, ...], run: Task) -> Path | None:
    """The figure of one map (:func:`figure_record`), NDR-QL's request run again with ``run``'s first seed, preset,
    weights and runner; panel 3 draws the region and guideline of the source that served (the record's
    ``ndr.served``)."""
    rec = figure_record(recs, grids)
    if rec is None:
        return None
    pc = one_case(gs, rec["index"], rec["grid"], parse_beliefs(rec["belief"])[0])
    task = dataclasses.replace(run, index=rec["index"], grid=rec["grid"], belief=rec["belief"], sense=False)
    request = plan_request(pc, task, "NDR-QL")
    with warnings.catch_warnings():  # the record of this map says them
        for category in (FallbackWarning, SnapWarning):
            warnings.simplefilter("ignore", category)
        report = run.runner(request)
    served = (rec.get("ndr") or {}).get("served") if _served(rec) else None
    gain = _oracle_gain(rec)
    why = ("the map where knowing the hidden part is worth most (oracle / IQL-BFS (belief), mean steps, "
           f"{gain:.3g})" if math.isfinite(gain) else "no map with the oracle's row")
    model = os.path.basename(str(request.weights_file)) if request.weights_file else "no model"
    title = (f"{run.set_name} map {rec['index']} ({rec['family']}), {rec['belief']}, grid {pc.case.n}: {why}\n"
             f"NDR-QL served by {served or 'fallback (IQL-BFS)'}; weights: {model}")
    fig = belief_figure(report, pc.belief, report.region, report.guideline, source=served, title=title)
    return save_figure(fig, path)


__all__ = ["FIGURE", "RECORDS", "REPORT", "belief_weights", "figure_record", "map_figure", "partial", "tasks_of"]
