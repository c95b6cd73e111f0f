#!/usr/bin/env python3
"""A model for belief maps on the development set: NDR-QL with its priors against IQL-BFS on the belief.

The cases are ``headroom.py``'s (same set, grids, masks from the same seeds, same truth and belief grids,
same ``general`` preset constants, same seeds of Q-learning), so its rows join this file's by ``(index, grid)``.
For each weights file given (``--weights A.pt,B.pt``; a row per file, named by its stem) the model predicts
region, guideline and goal distance on the **belief's** grid, seeing the planning cells that hold an unknown
pixel (:func:`ndrql.maps.belief.unknown_cells`, what ``plan --hide`` gives it) when its encoding has the
channel; NDR-QL then learns on the true grid with those priors (no judge, no fallback: the model's own
priors; :func:`ndrql.experiments.partial.model_job`, the row ``NDR-QL (model)`` of ``ndrql reproduce partial``).
``IQL-BFS (belief)`` is run again as the reference. ``ndrql reproduce partial`` runs the plan's own request
(judge and fallback included) as well.

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
from pathlib import Path

import numpy as np

from ndrql.experiments.partial import REF, BeliefSetting, model_job, partial_cases, plain_priors, run_rows
from ndrql.experiments.stats import geomean_ratio, outcomes
from ndrql.model.predict import Predictor
from ndrql.planning.preset import load_preset


def run_models(pc, models: dict[str, Predictor], preset, seeds: list[int]) -> dict:
    """IQL-BFS (belief) and, per model, NDR-QL with its own priors on the belief's grid
    (:func:`ndrql.experiments.partial.model_job`: what ``plan --hide``'s model source predicts, no judge)."""
    jobs = {REF: ("IQL-BFS", plain_priors("IQL-BFS", pc.bcase, preset), 0.0)}
    for name, p in models.items():
        jobs[name] = model_job(p, pc, preset)[0]
    out = run_rows(pc.case, jobs, preset, seeds)
    for row in out["rows"].values():  # the seconds of the prediction and priors, under this study's old name
        row["predict_seconds"] = row.pop("seconds")
    return out


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
            for pc in cases(args, grid):
                if (pc.index, grid) in done or pc.case is None:
                    continue
                rec = {"index": pc.index, "family": pc.family, "grid": grid, "kind": args.kind, "fraction": args.fraction,
                       "unknown_share": round(pc.unknown_share, 4), "set": args.set, "seeds": seeds,
                       "weights": args.weights, "n": pc.case.n, **run_models(pc, models, preset, seeds)}
                f.write(json.dumps(rec) + "\n")
                f.flush()
    return 0


def cases(args: argparse.Namespace, grid: int):
    """headroom's cases (:func:`ndrql.experiments.partial.partial_cases`: the same set, masks and grids)."""
    from ndrql.experiments.eval_sets import eval_set, eval_spec

    yield from partial_cases(eval_set(eval_spec(args.set), False), grid, BeliefSetting(args.kind, args.fraction), args.limit)


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
