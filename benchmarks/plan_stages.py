"""Plan's stages per map size: NDR-QL as ``plan`` runs it (the exact source on a known map), with the network's
priors (``--prior-from model``), and IQL-BFS, measured in one process on the same generated maps.

For each map size, ``--maps`` generated maps (families round-robin, seed ``--seed``, a development seed) are planned
with ``ndrql.solve`` at ``plan``'s defaults (safe grid, size auto; one seed, one worker). Printed per size and
configuration: the median, 95th percentile and maximum wall seconds of load + predict + priors, the whole in-process
work (predict + priors + learn, loading excluded) and its median ratio to IQL-BFS's on the same map, and the
planning grid's median side. The model is loaded once before the timings (its load is reported apart, cold).

    python benchmarks/plan_stages.py --sizes 201,401,801 --maps 12
    python benchmarks/plan_stages.py --sizes 600 --maps 6 --families ros_scan --own-pixels
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import ndrql
from ndrql.model.predict import load_predictor
from ndrql.synth.generate import SetSpec, generate_sample
from ndrql.synth.families import shipped_families

CONFIGS = {"NDR-QL (plan)": dict(methods=("NDR-QL",)),
           "NDR-QL (--prior-from model)": dict(methods=("NDR-QL",), predictions="model"),
           "IQL-BFS": dict(methods=("IQL-BFS",))}


def tail(xs: list[float]) -> str:
    return f"{np.median(xs):.3f} / {np.percentile(xs, 95):.3f} / {max(xs):.3f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="201,401,801", help="map sides in pixels")
    ap.add_argument("--maps", type=int, default=12, help="maps per size")
    ap.add_argument("--seed", type=int, default=948101, help="generation seed (development range)")
    ap.add_argument("--families", default=None, help="families, comma-separated (default: the shipped twelve)")
    ap.add_argument("--own-pixels", action="store_true", help="plan at the map's own pixels (--size = the map side)")
    a = ap.parse_args()
    fams = tuple(a.families.split(",")) if a.families else shipped_families()
    t0 = time.perf_counter()
    load_predictor("general", threads=1)
    print(f"model load (cold, once per process): {time.perf_counter() - t0:.3f} s")
    for side in (int(s) for s in a.sizes.split(",")):
        spec = SetSpec(fams, (side,), a.maps, a.seed)
        rows: dict[str, dict[str, list[float]]] = {k: {"pre": [], "work": [], "grid": []} for k in CONFIGS}
        for i in range(a.maps):
            raw = generate_sample(spec, i)
            extra = {"size": side, "max_size": max(side, 512)} if a.own_pixels else {}
            for name, kw in CONFIGS.items():
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    rep = ndrql.solve(raw.obstacles, start=raw.start, goal=raw.goal, seeds=(0,), workers=1,
                                      fallback=None if "model" in name else "auto", **kw, **extra)
                w = rep.timings
                rows[name]["pre"].append(w["load"] + w["predict"] + w["priors"])
                rows[name]["work"].append(w["predict"] + w["priors"] + w["learn"])
                rows[name]["grid"].append(max(rep.grid.shape))
        ref = rows["IQL-BFS"]["work"]
        print(f"\nmaps of {side} px ({a.maps}, grid median {np.median(rows['IQL-BFS']['grid']):.0f} cells); seconds "
              f"median / p95 / max")
        print("| configuration | load + predict + priors | predict + priors + learn | work / IQL-BFS's (median) |")
        print("|---|---:|---:|---:|")
        for name, r in rows.items():
            ratio = np.median([x / y for x, y in zip(r["work"], ref) if y > 0])
            print(f"| {name} | {tail(r['pre'])} | {tail(r['work'])} | {ratio:.2f}x |")


if __name__ == "__main__":
    main()
