"""Which orientations and which fallback cut should ``ndrql plan`` use? Measured as ``plan`` runs.

Each map of a development set (generated, seeds in the development range) is planned with
``ndrql.solve`` as ``ndrql plan`` plans a map file: the safe grid with ``--size auto``, the weights
and preset ``plan`` uses by default, smoothing on; IQL and NDR-QL (the model's priors, no fallback) on
the same seeds, for each count of orientations. A fallback cut ``c`` then means: NDR-QL's run where
the judged Eq. 7 threshold is at least ``c``, IQL's run elsewhere (what ``plan`` does). Printed per
(orientations, cut): maps where the rule beats IQL, the geometric mean of steps, the final path's
length over the map's own shortest route, and the predict stage's CPU time.

    PYTHONPATH=src python studies/plan_defaults/probe.py --per-family 3 --seeds 3 --out /tmp/probe.json
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

import ndrql
from ndrql.maps.astar import shortest_path8
from ndrql.pipeline.settings import PlanSettings
from ndrql.synth.families import family_names
from ndrql.synth.generate import SetSpec, generate_sample

#: The development set of this study (seed in the development range 900,000-949,999, unused by the
#: sets of transfer_sets.json).
DEV_SEED = 900_032
CUTS = (None, 0.3, 0.4, 0.5, 0.6)


def plan_map(raw, counts, seeds) -> dict:
    """IQL and NDR-QL on one map for each count of orientations (plan's defaults otherwise)."""
    shortest = shortest_path8(raw.obstacles, raw.start, raw.goal).cost
    out = {"family": raw.family, "side": int(raw.obstacles.shape[0]), "shortest_px": shortest, "by_count": {}}
    for k in counts:
        rep = ndrql.solve(raw.obstacles, raw.start, raw.goal, ("IQL", "NDR-QL"), list(seeds),
                          settings=PlanSettings(symmetries=k, fallback=None), workers=1)
        q = rep.info.get("prediction_quality", {})
        rows = {}
        for m in ("IQL", "NDR-QL"):
            rs = rep.runs(m)
            rows[m] = {"steps": [r.convergence_steps if r.converged else r.total_steps for r in rs],
                       "length": [None if r.route is None else r.route.length / shortest for r in rs]}
        out["by_count"][str(k)] = {"threshold": q.get("threshold"), "informative": q.get("informative"),
                                   "size": int(max(rep.grid.shape)), "predict_cpu": rep.cpu_times.get("predict"),
                                   "rows": rows}
    return out


def gmean(xs) -> float:
    return float(math.exp(np.mean(np.log(np.maximum(1, xs)))))


def table(records: list[dict], counts) -> list[str]:
    lines = ["| orientations | cut | falls back | beats IQL | ties/loses | steps (geo. mean) | path / shortest | predict CPU s |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    iql = [np.mean(r["by_count"][str(counts[0])]["rows"]["IQL"]["steps"]) for r in records]
    lines.insert(0, f"IQL alone: steps {gmean(iql):,.0f} (geometric mean over {len(records)} maps)")
    for k in counts:
        for cut in CUTS:
            steps, wins, falls, lengths = [], 0, 0, []
            for r, base in zip(records, iql):
                b = r["by_count"][str(k)]
                thd = b["threshold"]
                use_ndr = cut is None or (thd is not None and thd >= cut)
                row = b["rows"]["NDR-QL" if use_ndr else "IQL"]
                falls += not use_ndr
                s = float(np.mean(row["steps"]))
                steps.append(s)
                wins += s < base * 0.98
                lengths += [x for x in row["length"] if x is not None]
            pred = np.median([r["by_count"][str(k)]["predict_cpu"] for r in records])
            lines.append(f"| {k} | {'none' if cut is None else cut} | {falls} | {wins}/{len(records)} | "
                         f"{len(records) - wins} | {gmean(steps):,.0f} | {np.mean(lengths):.3f} | {pred:.2f} |")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-family", type=int, default=3)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--sizes", default="201")
    ap.add_argument("--counts", default="1,2,4")
    ap.add_argument("--out", default="probe.json")
    args = ap.parse_args()
    fams = family_names()
    fams = [f for f in ("blocks", "gaps", "bugtrap", "bugtraps", "gaps_blocks", "narrow_passage", "maze", "rooms",
                        "office", "scatter", "warehouse", "ros_scan") if f in fams]
    spec = SetSpec(tuple(fams), tuple(int(s) for s in args.sizes.split(",")), len(fams) * args.per_family, DEV_SEED)
    counts = tuple(int(c) for c in args.counts.split(","))
    records = []
    t0 = time.time()
    for i in range(spec.count):
        raw = generate_sample(spec, i)
        records.append(plan_map(raw, counts, range(args.seeds)))
        print(f"{i + 1}/{spec.count} {raw.family} {time.time() - t0:.0f} s", flush=True)
        with open(args.out, "w") as f:
            json.dump({"spec": spec.to_dict(), "records": records}, f)
    print("\n".join(table(records, counts)))


if __name__ == "__main__":
    main()
