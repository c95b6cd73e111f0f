#!/usr/bin/env python3
"""A model for belief maps on the development set: NDR-QL with its priors against IQL-BFS on the belief.

The cases are ``headroom.py``'s (same set, grids, masks from the same seeds, same truth and belief grids,
same ``general`` preset constants, same seeds of Q-learning), so its rows join this file's by ``(index, grid)``.
For each weights file given (``--weights A.pt,B.pt``; a row per file, named by its stem) the model predicts
region, guideline and goal distance on the **belief's** grid, seeing the planning cells that hold an unknown
pixel (:func:`ndrql.maps.belief.unknown_cells`, what ``plan --hide`` gives it) when its encoding has the
channel; NDR-QL then learns on the true grid with those priors (no judge, no fallback: the model's own
priors). ``IQL-BFS (belief)`` is run again as the reference.

    PYTHONPATH=src python studies/partial/model_eval.py --weights $NDRQL_CACHE/runs/belief-short-a/best.pt \\
        --grids 50,100 --kind blobs --fraction 0.3 --out results/partial/model-blobs30.jsonl
    PYTHONPATH=src python studies/partial/model_eval.py --report results/partial/model-blobs30.jsonl \\
        --headroom results/partial/blobs30.jsonl

The report gives, per model, the geometric mean of NDR-QL / IQL-BFS (belief) with a 95% bootstrap interval,
wins / ties / losses, per family, and (with ``--headroom``) the share of the oracle's gain it takes,
``(1 - model) / (1 - oracle)`` in geometric means over the maps both files hold. One process, one thread.
Development sets only: :func:`ndrql.experiments.eval_sets.eval_spec` refuses a sealed one.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import headroom  # noqa: E402  (the cases and rows of the headroom study)

from ndrql.experiments.stats import geomean_ratio, outcomes  # noqa: E402
from ndrql.maps.belief import unknown_cells  # noqa: E402
from ndrql.model.predict import Predictor  # noqa: E402
from ndrql.planning.methods import build_priors  # noqa: E402
from ndrql.planning.preset import load_preset  # noqa: E402
from ndrql.planning.priors import ThresholdWarning  # noqa: E402
from ndrql.planning.runner import astar_length, run_plan  # noqa: E402

REF = "IQL-BFS (belief)"


def case_unknown(case, belief_unknown: np.ndarray) -> np.ndarray:
    """The case's planning cells holding an unknown pixel (the safe grid's square cells of max(H, W) / n px)."""
    side = max(case.obstacles.shape) / case.n
    return unknown_cells(belief_unknown, SimpleNamespace(shape=case.blocked.shape, cell_size=(side, side)))


def run_models(case, bcase, unknown: np.ndarray, models: dict[str, Predictor], preset, seeds: list[int]) -> dict:
    n = max(case.blocked.shape)
    args = (case.start_cell, case.goal_cell)
    opt = astar_length(case.blocked, *args)
    rows: dict = {}
    jobs = {REF: ("IQL-BFS", build_priors("IQL-BFS", bcase.blocked, *args, cfg=preset.configs("IQL-BFS", grid=n)[1]), 0.0)}
    cfg = preset.configs("NDR-QL", grid=n)[1]
    for name, p in models.items():
        t0 = time.perf_counter()
        out = p.predict_view(bcase.blocked, *args, unknown=unknown if p.sees_unknown else None)
        seconds = time.perf_counter() - t0
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ThresholdWarning)
            jobs[name] = ("NDR-QL", build_priors("NDR-QL", bcase.blocked, *args, out.region, out.guideline, cfg,
                                                 out.distance), seconds)
    for row, (method, pri, predict_s) in jobs.items():
        ql = preset.configs(method, grid=n)[0]
        runs = [run_plan(case.blocked, *args, method, s, ql, priors=pri, astar=opt) for s in seeds]
        rows[row] = {"steps": [headroom.steps_of(r) for r in runs], "converged": [bool(r.converged) for r in runs],
                     "ratio": [r.length_ratio for r in runs], "predict_seconds": round(predict_s, 4)}
    return {"astar": opt, "rows": rows}


def measure(args: argparse.Namespace) -> int:
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    done = set()
    if out.exists():
        done = {(r["index"], r["grid"]) for r in map(json.loads, filter(str.strip, out.read_text().splitlines()))}
    models = {Path(w).stem if Path(w).stem not in ("best", "last") else Path(w).parent.name + "/" + Path(w).stem:
              Predictor.load(w, threads=1) for w in args.weights.split(",") if w.strip()}
    preset, seeds = load_preset(args.preset), list(range(args.seeds))
    with out.open("a") as f:
        for grid in [int(g) for g in args.grids.split(",")]:
            for i, fam, case, bcase, share, unknown_px in cases(args, grid):
                if (i, grid) in done or case is None:
                    continue
                rec = {"index": i, "family": fam, "grid": grid, "kind": args.kind, "fraction": args.fraction,
                       "unknown_share": round(share, 4), "set": args.set, "seeds": seeds, "weights": args.weights,
                       "n": case.n, **run_models(case, bcase, case_unknown(case, unknown_px), models, preset, seeds)}
                f.write(json.dumps(rec) + "\n")
                f.flush()
    return 0


def cases(args: argparse.Namespace, grid: int):
    """headroom's cases with the belief's unknown pixels (drawn again from the same generator state)."""
    from ndrql.experiments.eval_sets import eval_set, eval_spec
    from ndrql.synth.masks import KINDS, draw_belief

    gs = eval_set(eval_spec(args.set), False)
    for i, fam, case, bcase, share in headroom.cases(args.set, grid, args.kind, args.fraction, args.limit):
        raw = gs.raw(i)
        rng = np.random.default_rng([headroom.MASK_SEED, i, KINDS.index(args.kind), int(round(100 * args.fraction))])
        belief = draw_belief(args.kind, raw.obstacles, raw.start, raw.goal, rng, fraction=args.fraction)
        yield i, fam, case, bcase, share, belief.unknown


def _mean(rec: dict, row: str) -> float:
    return float(np.mean(rec["rows"][row]["steps"]))


def report(files: list[str], head_files: list[str]) -> int:
    recs = [json.loads(x) for f in files for x in Path(f).read_text().splitlines() if x.strip()]
    heads = {(r["index"], r["grid"]): r for f in head_files for x in Path(f).read_text().splitlines() if x.strip()
             for r in [json.loads(x)] if "rows" in r}
    for grid in sorted({r["grid"] for r in recs}):
        group = [r for r in recs if r["grid"] == grid]
        models = [m for m in group[0]["rows"] if m != REF]
        print(f"\n### {group[0]['kind']} {group[0]['fraction']:.0%}, grid {grid}: {len(group)} maps\n")
        for m in models:
            g = geomean_ratio([_mean(r, m) for r in group], [_mean(r, REF) for r in group])
            o = outcomes([r["rows"][m]["steps"] for r in group], [r["rows"][REF]["steps"] for r in group])
            line = (f"- {m}: NDR-QL / IQL-BFS (belief) **{g['ratio']:.3f}** ({g['low']:.3f} .. {g['high']:.3f}); "
                    f"wins / ties / losses {o['wins']} / {o['ties']} / {o['losses']}")
            both = [r for r in group if (r["index"], grid) in heads and "NDR-QL (oracle)" in heads[(r["index"], grid)]["rows"]]
            if both:
                orc = geomean_ratio([_mean(heads[(r["index"], grid)], "NDR-QL (oracle)") for r in both],
                                    [_mean(r, REF) for r in both])["ratio"]
                mod = geomean_ratio([_mean(r, m) for r in both], [_mean(r, REF) for r in both])["ratio"]
                line += f"; share of the oracle's gain on {len(both)} maps {(1 - mod) / (1 - orc):.1%} (oracle {orc:.3f})"
            print(line)
            fams = sorted({r["family"] for r in group})
            worst = max(fams, key=lambda fam: geomean_ratio([_mean(r, m) for r in group if r["family"] == fam],
                                                            [_mean(r, REF) for r in group if r["family"] == fam])["ratio"])
            sub = [r for r in group if r["family"] == worst]
            print(f"  worst family {worst}: {geomean_ratio([_mean(r, m) for r in sub], [_mean(r, REF) for r in sub])['ratio']:.3f} "
                  f"({len(sub)} maps)")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--weights", default="", help="weights files, comma-separated (a row each)")
    ap.add_argument("--set", default="partial-dev")
    ap.add_argument("--grids", default="50,100")
    ap.add_argument("--kind", default="blobs", choices=("blobs", "sensed", "outdated"))
    ap.add_argument("--fraction", type=float, default=0.3)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--preset", default="general")
    ap.add_argument("--limit", type=int, default=None, help="first N maps only")
    ap.add_argument("--out", default="results/partial/model-blobs30.jsonl")
    ap.add_argument("--report", nargs="+", metavar="FILE")
    ap.add_argument("--headroom", nargs="*", default=[], metavar="FILE", help="headroom.py results (the oracle's row)")
    args = ap.parse_args(argv)
    if args.report:
        return report(args.report, args.headroom)
    if not args.weights:
        ap.error("--weights is required to measure")
    return measure(args)


if __name__ == "__main__":
    sys.exit(main())
