"""Measure and record the path quality of a shipped preset on its own tuning set.

No preset ships whose learned greedy grid path exceeds the grid optimum by more than
:data:`ndrql.tuning.objective.PATH_BOUND` on the worst map of its tuning set (the mean over the check
seeds of greedy path / A* on that map). ``ndrql tune --export-preset`` applies the bound to what it
exports; this tool measures a preset that exists: each method's constants, per grid size, on the
problems its search used (``general``: per grid the set its search read, ``tune`` or ``large-dev2-128``, with
the shipped general weights; ``tuned``:
the paper's validation maps with the paper's weights), with the preset's check seeds and full episode
budget. It writes the figures into the preset's ``meta`` (``path_quality``) and exits 2 when searched
constants exceed the bound (entries that hold the paper's constants are reported, not judged). ``tests/tuning/test_path_bound.py`` checks every shipped preset's record.

    python tools/preset_path_check.py general      # grids 50, 100, 128 and 256, about 25 min of one core
    python tools/preset_path_check.py general --grids 128   # one grid's entry (under a minute); the others' records kept
    python tools/preset_path_check.py tuned --data ../shared/data/path-planning-dataset
"""

from __future__ import annotations

import argparse
import json
import sys

from ndrql.experiments.tune_maps import generated_problems
from ndrql.io import file_digest, write_json
from ndrql.model.weights import resolve_weights
from ndrql.planning.preset import Preset, builtin_path, load_preset
from ndrql.tuning.objective import evaluate, tuning_problems
from ndrql.tuning.objective import PATH_BOUND
from ndrql.tuning.report import path_verdict


def measure(preset: Preset, problems, seeds: list[int], grid: int | None, only: list[str] | None = None) -> dict[str, dict]:
    """Per method of the preset (or of ``only``): mean greedy path / A*, its 95th percentile and worst over
    maps, the worst run."""
    out = {}
    methods = preset.grids[grid] if grid is not None else preset.methods
    for m in [m for m in methods if only is None or m in only]:
        ql, pc = preset.configs(m, grid=grid)
        ev, _ = evaluate(problems, m, seeds, ql, pc)
        s = ev.summary()
        out[m] = {"mean": s["ratio"], "p95_map": s["p95_map"], "worst_map": s["worst_map"], "worst_run": s["worst_run"],
                  "not_converged": s["not_converged"], "runs": s["runs"]}
        print(f"{preset.name} grid {grid or 50} {m}: path / A* mean {s['ratio']:.3f}, p95 {s['p95_map']:.3f}, worst map "
              f"{s['worst_map']:.3f}, worst run {s['worst_run']:.3f}", flush=True)
    return out


def _refuse(message: str) -> int:
    print(f"preset_path_check: error: {message}", file=sys.stderr)
    return 2


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("preset", choices=("general", "tuned"), help="the shipped preset to measure")
    ap.add_argument("--data", help="dataset root (tuned: the paper's validation maps)")
    ap.add_argument("--methods", help="general: measure only these methods (comma-separated) and keep the record's "
                    "other entries (after a change of one method's constants)")
    ap.add_argument("--grids", help="general: measure only these grid entries (comma-separated) and keep the "
                    "record's other grids (after adding or changing one grid's entry)")
    args = ap.parse_args(argv)
    preset = load_preset(args.preset)
    meta = dict(preset.meta)
    if args.preset == "general":
        weights = resolve_weights("general")
        grids = dict(meta.get("path_quality", {}).get("grids", {})) if args.grids else {}
        chosen = {int(x) for x in args.grids.split(",")} if args.grids else set(preset.grids)
        if not chosen <= set(preset.grids):
            return _refuse(f"--grids {args.grids}: the preset has grids {sorted(preset.grids)}")
        for n in sorted(chosen):
            search = meta["grids"][str(n)]["search"]
            # an entry that keeps another entry's constants is measured where they were searched (``search["grid"]``)
            problems, _, _ = generated_problems(search["samples"], search.get("grid", n), "general",
                                                search.get("eval_set", "tune"))
            if [p.key for p in problems] != search["problems"]:
                return _refuse(f"grid {n}: the problems of set {search.get('eval_set', 'tune')!r} differ from the search's")
            only = args.methods.split(",") if args.methods else None
            old = meta.get("path_quality", {}).get("grids", {}).get(str(n), {}) if only else {}
            grids[str(n)] = {**old, **measure(preset, problems, meta["grids"][str(n)]["check_seeds"], n, only)}
        record = {"weights_sha256_16": file_digest(weights)[:16], "grids": grids}
    else:
        from ndrql.dataset.layout import resolve_root

        weights = resolve_weights("paper")
        search = meta["search"]
        problems, _, _ = tuning_problems(resolve_root(args.data), search["samples"], search["order_seed"], None)
        if [p.key for p in problems] != search["problems"]:
            return _refuse("the validation problems differ from the search's")
        record = {"weights_sha256_16": file_digest(weights)[:16], "grids": {"50": measure(preset, problems,
                                                                                         meta["check_seeds"], None)}}
    record["bound"] = PATH_BOUND
    path = builtin_path(args.preset)
    raw = json.loads(path.read_text())
    raw["meta"]["path_quality"] = record  # the file as it is, with one more provenance entry
    write_json(path, raw, indent=2)
    bad = path_verdict(record, preset)
    for line in bad:
        print(f"preset_path_check: {line}", file=sys.stderr)
    return 2 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
