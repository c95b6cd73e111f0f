#!/usr/bin/env python3
"""Prediction time per grid size and view: the shipped ``general`` model on ONNX Runtime, one thread.

    OMP_NUM_THREADS=1 PYTHONPATH=src nice -n 10 python studies/large_view/timing.py \\
        --sizes 32,64,128,256,512 --views native,cap:512,coarse:128 --repeat 3

For each size ``n`` an outdoor map of ``4n`` px (the first seed that connects) on its safe grid of ``n`` cells; the time is the
whole view path (draw the input, encode it, forward, bring region, guideline and distance back to the
grid), median of ``--repeat`` runs after one warm-up, for one orientation and for ``--symmetries``
(what ``plan`` averages over by default). The load average is printed with it: on a shared machine the
absolute times are upper bounds; the ratio to native at 64 cells (a 256 px input, measured in the
same run) is what carries over.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from ndrql.dataset.encodings import encode_input
from ndrql.dataset.views import GridView, view_cells, view_distance_cells, view_input
from ndrql.errors import NoPathError
from ndrql.maps.astar import astar4
from ndrql.maps.sizing import safe_grid
from ndrql.model.predict import Predictor
from ndrql.model.symmetry import averaged
from ndrql.synth import generate_map
from ndrql.synth.endpoints import sample_endpoints


def one(predictor: Predictor, blocked, s, g, view: GridView, symmetries: int) -> float:
    t0 = time.perf_counter()
    vi = view_input(blocked, s, g, view)
    r, gl, d = averaged(predictor._runner, encode_input(vi.image, vi.start, vi.goal, predictor.encoding)[None], symmetries)
    view_cells(r[0], vi), view_cells(gl[0], vi)
    if d is not None:
        view_distance_cells(d[0], vi)
    return time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="32,64,128,256,512")
    ap.add_argument("--views", default="native,cap:512,coarse:128")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--symmetries", type=int, default=4)
    args = ap.parse_args()
    predictor = Predictor.load("src/ndrql/data/ndr_general.onnx", threads=1)
    views = [GridView.parse(v) for v in args.views.split(",")]
    print(f"load average before: {os.getloadavg()[0]:.1f}")
    print("| cells | view | input px | 1 orientation (s) | " + f"{args.symmetries} orientations (s) |")
    print("|---:|---|---:|---:|---:|")
    for n in (int(x) for x in args.sizes.split(",")):
        for seed in range(50):  # the first seed whose start and goal connect on the grid
            rng = np.random.default_rng(seed)
            obstacles = generate_map("outdoor", rng, 4 * n, 4 * n)
            pair = sample_endpoints(rng, obstacles)
            if pair is None:
                continue
            pg = safe_grid(obstacles, n, *pair)
            blocked, s, g = pg.blocked, pg.start, pg.goal
            try:
                astar4(blocked, s, g)
            except NoPathError:
                continue
            break
        for view in views:
            one(predictor, blocked, s, g, view, 1)  # warm-up
            t1 = np.median([one(predictor, blocked, s, g, view, 1) for _ in range(args.repeat)])
            t4 = np.median([one(predictor, blocked, s, g, view, args.symmetries) for _ in range(args.repeat)])
            side = view_input(blocked, s, g, view).image.shape[0]
            print(f"| {n} | {view} | {side} | {t1:.3f} | {t4:.3f} |", flush=True)
    print(f"load average after: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
