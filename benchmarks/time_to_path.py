"""Wall-clock time to a usable path per planning-grid size: A*, IQL, NDR-QL with the model's prediction,
and the model's prediction alone, measured in the same run (docs/results.md#time-to-a-usable-path).

    .venv/bin/python benchmarks/time_to_path.py                     # grids 32, 64, 128, 256; 6 maps each
    .venv/bin/python benchmarks/time_to_path.py --grids 32,64 --maps 3

Maps: the development set ``transfer-small`` (every family, 201/401 px), the first ``--maps`` of at least as
many pixels as cells whose start and goal are at least half a side apart (Manhattan, in cells) and connect on the safe grid of each size (the same grid for every method; building it is not
timed). Per map and size, one thread, one run each (seed 0):

- **A\\***: the 4-connected A* search on the planning grid (``maps.astar.astar4``): the optimal grid path;
- **IQL**: priors and Q-learning until the convergence test holds (the ``general`` preset's IQL constants for
  the nearest grid), i.e. until the greedy path is usable;
- **NDR-QL**: the model's prediction on the grid (the ``general`` weights averaged over ``plan``'s default
  orientations), its priors and Q-learning until convergence (the preset's NDR-QL constants);
- **model alone**: the prediction only (what NDR-QL adds before learning).

Each figure is the median over the maps of a size of the CPU time of this process (one thread, so CPU time
is the wall time of an idle core; it is the steadier figure on a shared machine); the ratio is to A*'s
median of the same size in this run. Numba's kernels and the model are loaded and warmed up (A* and
the prediction at every size) before timing; the table prints the load average at the start and the end.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import numpy as np


def _timed(fn):
    """CPU time of this process (one thread: steadier than wall time on a shared machine) and the result."""
    t0 = time.process_time()
    out = fn()
    return time.process_time() - t0, out


def _x(ratio: float) -> str:
    """A ratio to A*: one decimal under 10, whole numbers above."""
    return f"{ratio:.1f}x" if ratio < 10 else f"{ratio:,.0f}x"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--grids", default="32,64,128,256", help="planning grid sizes (cells per side)")
    ap.add_argument("--maps", type=int, default=6, help="maps per size (default: 6)")
    args = ap.parse_args(argv)

    import torch

    torch.set_num_threads(1)
    from ndrql.experiments.ceiling import grid_case, model_priors
    from ndrql.experiments.eval_sets import eval_set, eval_spec
    from ndrql.maps.astar import astar4
    from ndrql.model.predict import Predictor
    from ndrql.model.symmetry import DEFAULT_COUNT
    from ndrql.model.weights import resolve_weights
    from ndrql.planning import kernel
    from ndrql.planning.preset import load_preset
    from ndrql.planning.runner import run_plan

    kernel.warm_up()
    preset = load_preset("general")
    predictor = Predictor.load(resolve_weights("general"), threads=1, backend="torch", symmetries=DEFAULT_COUNT)
    gs = eval_set(eval_spec("transfer-small"), progress=False)
    load0 = os.getloadavg()[0]
    rows = []
    for n in [int(x) for x in args.grids.split(",")]:
        cases = []
        for i in range(len(gs)):
            raw = gs.raw(i)
            if raw.obstacles.shape[0] < n:  # a cell of at least one map pixel
                continue
            c = grid_case(f"m{i}", str(gs.families[i]), raw.obstacles, raw.start, raw.goal, n)
            if c is not None and abs(c.start_cell[0] - c.goal_cell[0]) + abs(c.start_cell[1] - c.goal_cell[1]) >= n // 2:
                cases.append(c)
            if len(cases) == args.maps:
                break
        model_priors(predictor, "grid", cases[0])  # warm up this input size
        astar4(cases[0].blocked, cases[0].start_cell, cases[0].goal_cell)
        t = {"A*": [], "IQL": [], "NDR-QL": [], "model": [], "iql_ok": 0, "ndr_ok": 0}
        for c in cases:
            t["A*"].append(_timed(lambda: astar4(c.blocked, c.start_cell, c.goal_cell))[0])
            q, p = preset.configs("IQL", grid=n)
            dt, r = _timed(lambda: run_plan(c.blocked, c.start_cell, c.goal_cell, "IQL", 0, q, p))
            t["IQL"].append(dt)
            t["iql_ok"] += bool(r.converged)
            dm, pri = _timed(lambda: model_priors(predictor, "grid", c))
            q, p = preset.configs("NDR-QL", grid=n)
            dl, r = _timed(lambda: run_plan(c.blocked, c.start_cell, c.goal_cell, "NDR-QL", 0, q, p, pri[0], pri[1],
                                            distance=pri[2] if len(pri) > 2 else None))
            t["model"].append(dm)
            t["NDR-QL"].append(dm + dl)
            t["ndr_ok"] += bool(r.converged)
        med = {k: statistics.median(t[k]) for k in ("A*", "IQL", "NDR-QL", "model")}
        rows.append((n, len(cases), med, t["iql_ok"], t["ndr_ok"]))
        print(f"grid {n}: {len(cases)} maps; " + ", ".join(f"{k} {1000 * v:.1f} ms" for k, v in med.items()), flush=True)
    load1 = os.getloadavg()[0]
    print(f"\n{platform.processor() or platform.machine()}, {os.cpu_count()} logical cores, Python {platform.python_version()}, "
          f"torch {torch.__version__}; one thread; load average {load0:.1f} at the start, {load1:.1f} at the end\n")
    print("| grid (cells) | maps | A* | IQL | NDR-QL (prediction + learning) | model alone | IQL / A* | NDR-QL / A* | model / A* | converged (IQL, NDR-QL) |")
    print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for n, k, med, iok, nok in rows:
        a = med["A*"]
        print(f"| {n} | {k} | {1000 * a:.2f} ms | {1000 * med['IQL']:.1f} ms | {1000 * med['NDR-QL']:.0f} ms | "
              f"{1000 * med['model']:.0f} ms | {_x(med['IQL'] / a)} | {_x(med['NDR-QL'] / a)} | {_x(med['model'] / a)} | "
              f"{iok}/{k}, {nok}/{k} |")
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    raise SystemExit(main())
