"""Which of Eq. 6's distances loses on large grids? NDR-QL re-run on the maps of a transfer report whose
prediction can guide planning, with the model's region and guideline and four distances in Eq. 6:

- ``learned``: the model's distance head (what ``plan`` does);
- ``line``: the straight line (the paper);
- ``exact``: the BFS distance to the goal through free space (the oracle's distance);
- ``region``: the moves to the goal through the thresholded region (``PriorConfig.region_distance``).

One JSON line per map: its key, family, planning grid, Eq. 7 threshold, and per distance NDR-QL's mean
steps over IQL's (IQL's steps read from the report, same seeds) and the worst greedy path over A*.
large_view/history.md#distance-through-the-region::

    PYTHONPATH=src python studies/large_view/distance_variants.py --set large-dev2-256 --grid 256 \\
        --report DIR/summary.json --out variants.jsonl [--part 0 --parts 2] [--uninformative]

``--report``: the ``summary.json`` of ``ndrql reproduce transfer`` on the same set and grid (its IQL and
oracle runs are reused; its seeds are used). ``--uninformative``: the maps whose prediction ``plan``
calls uninformative instead (those with an Eq. 7 threshold at all).
"""

from __future__ import annotations

import argparse
import dataclasses
import json

import numpy as np

from ndrql.errors import NdrqlError
from ndrql.experiments.ceiling import grid_case, larger_sizes
from ndrql.experiments.eval_sets import eval_set, eval_spec
from ndrql.experiments.transfer import _runs, row_configs
from ndrql.maps.grid import bfs_distances
from ndrql.model.predict import Predictor
from ndrql.model.weights import resolve_weights
from ndrql.pipeline.fallback import region_verdict
from ndrql.pipeline.predictions import predict_on_grid
from ndrql.planning.config import PriorConfig
from ndrql.planning.preset import load_preset

ROW = "NDR-QL (model)"
DISTANCES = ("learned", "line", "exact", "region")


def _mean(xs) -> float:
    return float(sum(xs)) / len(xs)


def map_row(record: dict, case, predictor, preset, seeds: list[int], distances: tuple[str, ...],
            uninformative: bool) -> dict | None:
    """The line of one map, or ``None`` when it is not one of the maps asked for."""
    b, s, g = case.blocked, case.start_cell, case.goal_cell
    region, guide, _, learned = predict_on_grid(predictor, b, s, g, PriorConfig())
    thd, cover, why = region_verdict(region, b, s, g, PriorConfig())
    if thd is None or (why is not None) != uninformative:
        return None
    ql, pc = row_configs(preset, grid=case.n)[ROW]
    iql = _mean(record["runs"]["IQL"]["steps"])
    row = {"key": record["key"], "family": record["family"], "n": case.n, "threshold": thd, "cover": cover,
           "oracle": _mean(record["runs"]["NDR-QL (oracle)"]["steps"]) / iql}
    for name in distances:
        cfg, dist = pc, learned
        if name == "line":
            dist = None
        elif name == "exact":
            dist = bfs_distances(b, g).astype(np.float64)
        elif name == "region":
            cfg = dataclasses.replace(pc, region_distance=1)
        priors = [region, guide] if dist is None else [region, guide, dist]
        out = _runs(b, s, g, {ROW: priors}, seeds, {ROW: (ql, cfg)})[ROW]
        row[name] = _mean(out["steps"]) / iql
        row[name + "_path"] = max((x for x in out["ratio"] if x is not None), default=None)
    return row


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--set", required=True)
    ap.add_argument("--grid", type=int, required=True)
    ap.add_argument("--report", required=True, help="summary.json of the transfer report on this set and grid")
    ap.add_argument("--out", required=True)
    ap.add_argument("--weights", default="general")
    ap.add_argument("--preset", default="general")
    ap.add_argument("--distances", default=",".join(DISTANCES))
    ap.add_argument("--part", type=int, default=0)
    ap.add_argument("--parts", type=int, default=1)
    ap.add_argument("--uninformative", action="store_true")
    a = ap.parse_args(argv)
    try:
        spec = eval_spec(a.set)  # refuses a sealed set: only the release report evaluates one
    except NdrqlError as exc:
        raise SystemExit(str(exc)) from None
    report = json.load(open(a.report))
    predictor = Predictor.load(resolve_weights(a.weights), threads=1, backend="torch")
    preset = load_preset(a.preset)
    generated = eval_set(spec, False)
    distances = tuple(a.distances.split(","))
    with open(a.out, "w") as fh:
        for k, record in enumerate(report["records"]):
            if record.get("skipped") or k % a.parts != a.part:
                continue
            family, i, _ = record["key"].rsplit("-", 2)
            raw = generated.raw(int(i))
            case = grid_case(record["key"], family, raw.obstacles, raw.start, raw.goal, a.grid, larger_sizes(a.grid))
            row = map_row(record, case, predictor, preset, list(report["seeds"]), distances, a.uninformative)
            if row is not None:
                fh.write(json.dumps(row) + "\n")
                fh.flush()


if __name__ == "__main__":
    main()
