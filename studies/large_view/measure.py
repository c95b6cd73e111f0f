#!/usr/bin/env python3
"""Measure how the shipped ``general`` model does on large grids under each view (ndrql.dataset.views).

    OMP_NUM_THREADS=1 PYTHONPATH=src nice -n 10 python studies/large_view/measure.py \\
        --set large-dev-128 --grid 128 --views native,cap:256,coarse:64 --plan-per-family 1 --seeds 0,1 \\
        --out ~/.cache/ndrql/studies/large_view/dev128

For every map of a development set (never a sealed one: refused) and the safe grid of ``--grid`` cells
(maps whose start and goal do not connect at that size are counted and skipped), per view:

- the Eq. 7 threshold ``plan`` judges the prediction with (paper schedule 0.99, 0.98, ...); below 0.5
  (or none) the prediction is *uninformative* and ``plan`` falls back to IQL;
- region F1 per map against the oracle's region on the same grid (cells >= 0.5), and the share of the
  oracle's path cells inside the predicted region at the judged threshold (*path recall*);
- the forward pass time (ONNX Runtime, one thread, one orientation).

On the first ``--plan-per-family`` connected maps of each family it runs IQL, NDR-QL with each view's
priors and NDR-QL with the oracle's, seeds ``--seeds``, constants of the ``general`` preset at the grid.
One JSON record per map goes to ``--out`` (a rerun skips maps already done); ``summary.py`` tabulates.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from ndrql.dataset.encodings import encode_input
from ndrql.dataset.views import GridView, view_cells, view_distance_cells, view_input
from ndrql.experiments.ceiling import grid_case, oracle_priors
from ndrql.experiments.transfer import eval_set, eval_spec, row_configs
from ndrql.io import write_json
from ndrql.model.predict import Predictor
from ndrql.model.symmetry import averaged
from ndrql.pipeline.predictions import MIN_THRESHOLD
from ndrql.planning.config import PriorConfig
from ndrql.planning.preset import load_preset
from ndrql.planning.priors import adaptive_threshold
from ndrql.planning.runner import run_plan


def predict_view(predictor: Predictor, blocked: np.ndarray, s, g, view: GridView, symmetries: int = 1):
    """Region, guideline and distance per planning cell under ``view``, and the forward pass's seconds."""
    vi = view_input(blocked, s, g, view)
    t0 = time.perf_counter()
    x = encode_input(vi.image, vi.start, vi.goal, predictor.encoding)[None]
    r, gl, d = averaged(predictor._runner, x, symmetries)  # the study needs the raw runner: predict.py has no views yet
    seconds = time.perf_counter() - t0
    region, guide = view_cells(r[0], vi), view_cells(gl[0], vi)
    dist = None if d is None else view_distance_cells(d[0], vi)
    return (region, guide, dist), seconds, int(vi.image.shape[0])


def f1(pred: np.ndarray, label: np.ndarray) -> float:
    tp = float((pred & label).sum())
    denom = float(pred.sum() + label.sum())
    return 2 * tp / denom if denom else 1.0


def steps_of(blocked, s, g, method, seeds, configs, priors) -> list[int]:
    ql, pc = configs[method]
    region, guide, dist = priors if priors is not None else (None, None, None)
    out = []
    for seed in seeds:
        r = run_plan(blocked, s, g, method.split(" ")[0], seed, ql, pc, region, guide, distance=dist)
        out.append(int(r.convergence_steps if r.converged else r.total_steps))
    return out


def measure_map(predictor, case, views: list[GridView], plan: bool, seeds: list[int], configs,
                baseline: dict | None = None) -> dict:
    oracle = oracle_priors(case, distance=True)
    label = oracle[0] >= 0.5
    on_path = oracle[1] >= 0.5
    rec: dict = {"n": case.n, "views": {}}
    priors = {}
    for view in views:
        pr, seconds, side = predict_view(predictor, case.blocked, case.start_cell, case.goal_cell, view)
        thd = adaptive_threshold(pr[0], case.blocked, case.start_cell, case.goal_cell, PriorConfig())
        inside = pr[0] > (thd if thd is not None else 0.0)
        rec["views"][str(view)] = {
            "threshold": thd, "uninformative": thd is None or thd < MIN_THRESHOLD,
            "f1": f1(pr[0] >= 0.5, label), "path_recall": float((inside & on_path).sum() / max(1, on_path.sum())),
            "seconds": seconds, "side": side}
        priors[str(view)] = pr
    if plan:
        t0 = time.perf_counter()
        args = (case.blocked, case.start_cell, case.goal_cell)
        if baseline is not None:  # the same map, grid, seeds and constants measured before: the runs are seeded
            rec["steps"] = {k: baseline[k] for k in ("IQL", "oracle")}
        else:
            rec["steps"] = {"IQL": steps_of(*args, "IQL", seeds, configs, None),
                            "oracle": steps_of(*args, "NDR-QL", seeds, configs, oracle)}
        for name, pr in priors.items():
            rec["steps"][name] = steps_of(*args, "NDR-QL", seeds, configs, pr)
        rec["plan_seconds"] = time.perf_counter() - t0
    return rec


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", default="large-dev-128")
    ap.add_argument("--grid", type=int, default=128)
    ap.add_argument("--views", default="native,cap:512,coarse:128")
    ap.add_argument("--plan-per-family", type=int, default=1)
    ap.add_argument("--seeds", default="0,1")
    ap.add_argument("--weights", default=None, help="default: the shipped general model")
    ap.add_argument("--limit", type=int, default=None, help="only the first N maps of the set")
    ap.add_argument("--baseline", type=Path, default=None,
                    help="an earlier --out of the same set, grid and seeds: take IQL's and the oracle's steps from it")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    spec = eval_spec(args.set)
    if spec.seed >= 950_000:
        raise SystemExit(f"{args.set} is a sealed set: only the release report evaluates on it")
    views = [GridView.parse(v) for v in args.views.split(",") if v.strip()]
    seeds = [int(s) for s in args.seeds.split(",") if s.strip()]
    predictor = Predictor.load(args.weights or "src/ndrql/data/ndr_general.onnx", threads=1)
    preset = load_preset("general")
    configs = {m: row_configs(preset, grid=args.grid)[r] for m, r in (("IQL", "IQL"), ("NDR-QL", "NDR-QL (model)"))}
    gs = eval_set(spec, progress=False)
    args.out.mkdir(parents=True, exist_ok=True)
    planned: dict[str, int] = {}
    for i in range(min(len(gs), args.limit or len(gs))):
        raw = gs.raw(i)
        fam = str(gs.families[i])
        path = args.out / f"{i:04d}-{fam}.json"
        if path.exists():
            rec = json.loads(path.read_text())
            planned[fam] = planned.get(fam, 0) + ("steps" in rec)
            continue
        case = grid_case(f"{fam}-{i}", fam, raw.obstacles, raw.start, raw.goal, args.grid)
        if case is None:
            write_json(path, {"index": i, "family": fam, "px": int(raw.obstacles.shape[0]), "skipped": True})
            continue
        plan = planned.get(fam, 0) < args.plan_per_family
        base = None
        if args.baseline is not None and (args.baseline / path.name).exists():
            base = json.loads((args.baseline / path.name).read_text()).get("steps")
        rec = measure_map(predictor, case, views, plan, seeds, configs, base)
        planned[fam] = planned.get(fam, 0) + plan
        write_json(path, {"index": i, "family": fam, "px": int(raw.obstacles.shape[0]), "skipped": False, **rec})
        brief = " ".join(f"{k}:{v['threshold']}" for k, v in rec["views"].items())
        print(f"{i} {fam} {raw.obstacles.shape[0]}px {brief} {rec.get('steps', '')}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
