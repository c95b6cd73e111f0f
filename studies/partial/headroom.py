#!/usr/bin/env python3
"""How much can knowing the unknown be worth? The oracle's headroom over IQL-BFS on belief maps.

For every map of a development set (default ``partial-dev``), planning grid ``n`` and belief kind
(:mod:`ndrql.synth.masks`: blobs hiding a share of the free space, what a robot sensed along routes, an
outdated map), the agent learns on the **true** map's safe grid while the priors are computed from the
**belief** (unknown counted free), on the belief's safe grid of the same size (start and goal cells:
the truth's; the size: the first of the ladder from ``n`` on which the truth connects, as
``reproduce transfer``). Rows, with the same seeds and the ``general`` preset's constants for the grid:

- ``IQL``: no map in its priors (straight-line distance);
- ``IQL-BFS (belief)``: Eq. 5 on the exact BFS distance of the belief: the natural model-free reference;
- ``NDR-QL (belief)``: NDR-QL with exact priors of the belief (the oracle's region and guideline of the
  belief grid's shortest path, its exact BFS distance, Eq. 7 on the belief grid): a perfect model of
  what is *known*;
- ``NDR-QL (oracle)``: NDR-QL with the oracle's priors of the true grid: the ceiling, a model that knows
  what is hidden;
- ``IQL-BFS (truth)``: IQL-BFS on the true map: what full knowledge gives the model-free reference.

The cases, the masks and the rows' runs are :mod:`ndrql.experiments.partial`'s (``ndrql reproduce partial``).
Steps are convergence steps (total steps of a run that did not converge). Results go to a JSON-lines
file, one line per case (resumable); ``--report FILE...`` prints per-family geometric means and the
headroom ``1 - oracle / IQL-BFS (belief)`` with a 95% bootstrap interval over maps.

    PYTHONPATH=src python studies/partial/headroom.py --grids 50,100 --kind blobs --fraction 0.3 --out results/partial/blobs30.jsonl
    PYTHONPATH=src python studies/partial/headroom.py --report results/partial/blobs30.jsonl

One process, no workers (the machine's two cores are shared). Development sets only (the code refuses a
sealed one).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from ndrql.experiments.eval_sets import eval_set, eval_spec
from ndrql.experiments.partial import (BeliefSetting, oracle_job, partial_cases, plain_priors,
                                       run_rows)
from ndrql.experiments.stats import geomean_ratio, outcomes
from ndrql.maps.sizing import connected4
from ndrql.planning.preset import load_preset
from ndrql.synth.masks import KINDS

ROWS = ("IQL", "IQL-BFS (belief)", "NDR-QL (belief)", "NDR-QL (oracle)", "IQL-BFS (truth)")


def run_case(case, bcase, preset, seeds: list[int]) -> dict:
    """Every row with every seed: steps, path / A*, converged, and the seconds of each row's priors
    (:func:`ndrql.experiments.partial.run_rows`; ``NDR-QL (belief)``: the oracle's priors of the belief's grid)."""
    jobs = {"IQL": ("IQL", plain_priors("IQL", case, preset), 0.0),
            "IQL-BFS (belief)": ("IQL-BFS", plain_priors("IQL-BFS", bcase, preset), 0.0),
            "NDR-QL (oracle)": oracle_job(case, preset),
            "IQL-BFS (truth)": ("IQL-BFS", plain_priors("IQL-BFS", case, preset), 0.0)}
    if connected4(bcase.blocked, bcase.start_cell, bcase.goal_cell):
        jobs["NDR-QL (belief)"] = oracle_job(bcase, preset)
    return run_rows(case, {row: jobs[row] for row in ROWS if row in jobs}, preset, seeds)


def cases(set_name: str, grid: int, kind: str, fraction: float, limit: int | None):
    """``(index, family, case, belief case, unknown share)`` of every map (:func:`ndrql.experiments.partial.partial_cases`;
    case and belief case ``None`` when no ladder size from ``grid`` connects the map)."""
    gs = eval_set(eval_spec(set_name), False)
    for pc in partial_cases(gs, grid, BeliefSetting(kind, fraction), limit):
        yield pc.index, pc.family, pc.case, pc.bcase, pc.unknown_share


def measure(args: argparse.Namespace) -> int:
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    done = set()
    if out.exists():
        done = {(r["index"], r["grid"]) for r in map(json.loads, filter(str.strip, out.read_text().splitlines()))}
    preset = load_preset(args.preset)
    seeds = list(range(args.seeds))
    with out.open("a") as f:
        for grid in [int(g) for g in args.grids.split(",")]:
            for i, fam, case, bcase, share in cases(args.set, grid, args.kind, args.fraction, args.limit):
                if (i, grid) in done:
                    continue
                rec = {"index": i, "family": fam, "grid": grid, "kind": args.kind, "fraction": args.fraction,
                       "unknown_share": round(share, 4), "set": args.set, "seeds": seeds, "preset": args.preset}
                if case is None:
                    rec["skipped"] = "start and goal do not connect on the ladder"
                else:
                    t0 = time.perf_counter()
                    rec.update(n=case.n, shape=list(case.blocked.shape),
                               belief_blocked_share=round(float(bcase.blocked.mean()), 4),
                               truth_blocked_share=round(float(case.blocked.mean()), 4), **run_case(case, bcase, preset, seeds))
                    rec["seconds"] = round(time.perf_counter() - t0, 3)
                f.write(json.dumps(rec) + "\n")
                f.flush()
                if args.verbose:
                    print(f"{grid} {i} {fam} {rec.get('seconds', 'skip')}", file=sys.stderr, flush=True)
    return 0


def _mean(rec: dict, row: str) -> float:
    return float(np.mean(rec["rows"][row]["steps"]))


def report(files: list[str]) -> int:
    recs = [json.loads(line) for f in files for line in Path(f).read_text().splitlines() if line.strip()]
    for (kind, frac, grid) in sorted({(r["kind"], r["fraction"], r["grid"]) for r in recs}):
        group = [r for r in recs if (r["kind"], r["fraction"], r["grid"]) == (kind, frac, grid) and "rows" in r]
        skipped = sum(1 for r in recs if (r["kind"], r["fraction"], r["grid"]) == (kind, frac, grid) and "rows" not in r)
        full = [r for r in group if all(row in r["rows"] for row in ROWS)]
        share = np.mean([r["unknown_share"] for r in group]) if group else math.nan
        print(f"\n### {kind}" + (f" {frac:.0%}" if kind == "blobs" else "") + f", grid {grid}: {len(full)} maps "
              f"({skipped} not connected, {len(group) - len(full)} with the belief disconnected), unknown share of "
              f"free space {share:.2f}, seeds {len(full[0]['seeds']) if full else 0}\n")
        ref = "IQL-BFS (belief)"
        print("| family | maps | " + " | ".join(f"{row} / {ref}" for row in ROWS if row != ref) + f" | {ref} steps |")
        print("|---|---:|" + "---:|" * (len(ROWS) - 1) + "---:|")
        fams = sorted({r["family"] for r in full})
        for fam in [*fams, "all"]:
            sub = [r for r in full if fam in ("all", r["family"])]
            base = [_mean(r, ref) for r in sub]
            cells = [f"{geomean_ratio([_mean(r, row) for r in sub], base)['ratio']:.2f}" for row in ROWS if row != ref]
            gm = math.exp(np.mean(np.log(base)))
            print(f"| {'**all**' if fam == 'all' else fam} | {len(sub)} | " + " | ".join(cells) + f" | {gm:,.0f} |")
        if full:  # the headroom over every map with both rows (a disconnected belief still runs IQL-BFS)
            both = [r for r in group if "NDR-QL (oracle)" in r["rows"] and ref in r["rows"]]
            g = geomean_ratio([_mean(r, "NDR-QL (oracle)") for r in both], [_mean(r, ref) for r in both])
            b = geomean_ratio([_mean(r, "NDR-QL (belief)") for r in full], [_mean(r, ref) for r in full])
            o = outcomes([r["rows"]["NDR-QL (oracle)"]["steps"] for r in both], [r["rows"][ref]["steps"] for r in both])
            print(f"\nheadroom of the oracle over IQL-BFS (belief) on {len(both)} maps, 1 - geometric mean of oracle / "
                  f"IQL-BFS: **{1 - g['ratio']:.1%}** (95% bootstrap {1 - g['high']:.1%} .. {1 - g['low']:.1%}); oracle "
                  f"clearly better / tie / worse on {o['wins']} / {o['ties']} / {o['losses']} maps. NDR-QL with exact "
                  f"priors of the belief / IQL-BFS (belief) on {len(full)} maps: {b['ratio']:.2f} ({b['low']:.2f} .. "
                  f"{b['high']:.2f}).")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--set", default="partial-dev")
    ap.add_argument("--grids", default="50,100")
    ap.add_argument("--kind", default="blobs", choices=KINDS)
    ap.add_argument("--fraction", type=float, default=0.3, help="share of free space hidden (blobs)")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--preset", default="general")
    ap.add_argument("--limit", type=int, default=None, help="first N maps only")
    ap.add_argument("--out", default="results/partial/blobs30.jsonl")
    ap.add_argument("--report", nargs="+", metavar="FILE", help="print the tables of these result files")
    ap.add_argument("--verbose", action="store_true")
    args = ap.parse_args(argv)
    return report(args.report) if args.report else measure(args)


if __name__ == "__main__":
    raise SystemExit(main())
