#!/usr/bin/env python3
"""Revealed as it moves: when should the planner recompute its priors? (issue 54, item 2)

The maps, grids, masks and constants of ``headroom.py`` (blobs hiding a share of the free space); the robot
senses every cell within ``--radius`` (a share of the grid's longer side) by line of sight on the true grid
from each cell it stands on (:mod:`ndrql.pipeline.sensing`); IQL-BFS's priors are rebuilt on the grown
belief every ``E`` episodes with the Q-table kept. Rows, same seeds:

- ``static``: IQL-BFS on the initial belief, nothing recomputed (``headroom.py``'s IQL-BFS (belief));
- ``every E``: sensing on, recomputed every E episodes (a chunk that reveals nothing doubles the next);
- ``truth``: IQL-BFS on the true map (the ceiling, as the oracle in ``headroom.py``).

    PYTHONPATH=src python studies/partial/sense.py --grids 50 --every 5,20,100 --out results/partial/sense50.jsonl
    PYTHONPATH=src python studies/partial/sense.py --report results/partial/sense50.jsonl

One process (the machine's two cores are shared); development sets only.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from ndrql.experiments.ceiling import grid_case, larger_sizes
from ndrql.experiments.eval_sets import eval_set, eval_spec
from ndrql.experiments.stats import geomean_ratio
from ndrql.maps.safe import conservative_grid
from ndrql.pipeline.sensing import SenseConfig, run_sensed
from ndrql.planning.methods import build_priors
from ndrql.planning.preset import load_preset
from ndrql.planning.runner import run_plan
from ndrql.experiments.partial import BeliefSetting  # the masks of headroom.py and ndrql reproduce partial


def measure(args: argparse.Namespace) -> int:
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    done = {(r["index"], r["grid"]) for r in map(json.loads, out.read_text().splitlines())} if out.exists() else set()
    preset = load_preset(args.preset)
    seeds = list(range(args.seeds))
    every = [int(e) for e in args.every.split(",")]
    gs = eval_set(eval_spec(args.set), False)
    with out.open("a") as f:
        for grid in [int(g) for g in args.grids.split(",")]:
            for i in range(len(gs) if args.limit is None else min(args.limit, len(gs))):
                if (i, grid) in done:
                    continue
                raw, fam = gs.raw(i), str(gs.families[i])
                belief = BeliefSetting("blobs", args.fraction).draw(raw.obstacles, raw.start, raw.goal, i)
                case = grid_case(f"{fam}-{i}", fam, raw.obstacles, raw.start, raw.goal, grid, larger_sizes(grid))
                rec = {"index": i, "family": fam, "grid": grid, "fraction": args.fraction, "radius": args.radius,
                       "seeds": seeds}
                if case is None:
                    f.write(json.dumps({**rec, "skipped": True}) + "\n")
                    continue
                s, g = case.start_cell, case.goal_cell
                bel = conservative_grid(belief.planner_obstacles("free"), case.n)
                bel[s] = bel[g] = False
                known = ~conservative_grid(belief.unknown, case.n)
                known[s] = known[g] = True
                n = max(case.blocked.shape)
                ql, pc = preset.configs("IQL-BFS", grid=n)
                priors_on = lambda b, known=None: build_priors("IQL-BFS", b, s, g, cfg=pc)  # noqa: E731
                radius = max(1.0, args.radius * n)
                t0 = time.perf_counter()
                rows: dict = {}
                for name, blocked in (("static", bel), ("truth", case.blocked)):
                    pri = priors_on(blocked)
                    runs = [run_plan(case.blocked, s, g, "IQL-BFS", sd, ql, priors=pri) for sd in seeds]
                    rows[name] = {"steps": [int(r.convergence_steps if r.converged else r.total_steps) for r in runs],
                                  "converged": [bool(r.converged) for r in runs]}
                for e, carry in [(e, c) for c in args.carry.split(",") for e in every]:
                    runs = [run_sensed(case.blocked, bel, known, s, g, "IQL-BFS", sd, ql, priors_on,
                                       SenseConfig(radius=radius, every=e, carry=carry)) for sd in seeds]
                    rows[f"every {e}" + ("" if carry == "shift" else f", {carry}")] = {"steps": [r.steps for r in runs], "converged": [r.converged for r in runs],
                                          "recomputes": [r.recomputes for r in runs],
                                          "known_end": [round(r.known_share[-1], 4) if r.known_share else None
                                                        for r in runs]}
                rec.update(n=case.n, known_start=round(float(known.mean()), 4), rows=rows,
                           seconds=round(time.perf_counter() - t0, 2))
                f.write(json.dumps(rec) + "\n")
                f.flush()
                print(f"{grid} {i} {fam} {rec['seconds']}", file=sys.stderr, flush=True)
    return 0


def report(files: list[str]) -> int:
    recs = [json.loads(x) for f in files for x in Path(f).read_text().splitlines() if x.strip()]
    for grid in sorted({r["grid"] for r in recs}):
        g = [r for r in recs if r["grid"] == grid and "rows" in r]
        names = list(g[0]["rows"])
        base = [float(np.mean(r["rows"]["static"]["steps"])) for r in g]
        print(f"\n### grid {grid}: {len(g)} maps, blobs {g[0]['fraction']:.0%}, sensing radius {g[0]['radius']:.0%} of "
              f"the side, seeds {len(g[0]['seeds'])}\n")
        print("| row | steps / static (geometric mean, 95% bootstrap) | gain over static captured of the truth's | "
              "recomputes (median) | not converged |")
        print("|---|---:|---:|---:|---:|")
        truth = geomean_ratio([float(np.mean(r["rows"]["truth"]["steps"])) for r in g], base)["ratio"]
        for name in names:
            x = geomean_ratio([float(np.mean(r["rows"][name]["steps"])) for r in g], base)
            captured = (1 - x["ratio"]) / (1 - truth) if truth < 1 else math.nan
            rc = [v for r in g for v in r["rows"][name].get("recomputes", [])]
            nc = sum(v is False for r in g for v in r["rows"][name]["converged"])
            print(f"| {name} | {x['ratio']:.3f} ({x['low']:.3f} .. {x['high']:.3f}) | {captured:.0%} | "
                  f"{np.median(rc) if rc else '-'} | {nc} |")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--set", default="partial-dev")
    ap.add_argument("--grids", default="50")
    ap.add_argument("--fraction", type=float, default=0.3)
    ap.add_argument("--radius", type=float, default=0.08, help="sensing radius, share of the grid's longer side")
    ap.add_argument("--every", default="5,20,100", help="episodes between recomputations, comma-separated")
    ap.add_argument("--carry", default="shift", help="what a rebuild does to the Q-table: shift, reset, keep "
                    "(comma-separated for several rows)")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--preset", default="general")
    ap.add_argument("--limit", type=int, default=None)
    ap.add_argument("--out", default="results/partial/sense50.jsonl")
    ap.add_argument("--report", nargs="+", metavar="FILE")
    args = ap.parse_args(argv)
    return report(args.report) if args.report else measure(args)


if __name__ == "__main__":
    raise SystemExit(main())
