#!/usr/bin/env python3
"""Figures and numbers of docs/real-maps.md: the office plan before (the paper's grid) and after (the safe grid).

    .venv/bin/python tools/real_maps_figures.py            # writes docs/real-maps-office.png, prints the numbers

Draws the 2000x2000 office plan of the tests (``ndrql.synth.drawn``: 8 px walls, 60 px doors), plans
on it with the paper's 50x50 area grid and with the default safe grid, and draws both side by side
with their paths on the full map (red crosses: segments through walls). Also times the map-to-grid
downscale (the O(pixels) form against the dense product it replaced) and writes the office as a ROS
``map_server`` map (``out/real-maps/office.yaml`` + ``.pgm``, 5 cm per pixel) for the ROS example.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np

from ndrql.synth.drawn import OFFICE_GOAL, OFFICE_START, office_plan

ROOT = Path(__file__).resolve().parents[1]

OUT = ROOT / "out" / "real-maps"


def dense_planning_grid(arr: np.ndarray, size: int) -> np.ndarray:
    """The downscale before: dense overlap matrices (kept here only to time it)."""
    from ndrql.maps.grid import _overlap_matrix

    h, w = arr.shape
    rows, cols = _overlap_matrix(h, size), _overlap_matrix(w, size)
    return 2 * (rows @ arr.astype(np.int64) @ cols.T) >= h * w


def best_of(fn, n: int = 3) -> float:
    out = []
    for _ in range(n):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return min(out)


def downscale_timings() -> None:
    from ndrql.maps.grid import planning_grid
    from ndrql.maps.safe import conservative_grid, inflate
    from ndrql.dataset.render import to_model_input

    rng = np.random.default_rng(0)
    for side in (2000, 4000):
        m = rng.random((side, side)) < 0.2
        m[0, 0] = m[-1, -1] = False
        new = best_of(lambda: planning_grid(m, 256))
        safe = best_of(lambda: conservative_grid(m, 256))
        model = best_of(lambda: to_model_input(m, (0, 0), (side - 1, side - 1)))
        infl = best_of(lambda: inflate(m, 6), 1)
        line = (f"{side}x{side}: area grid 256 {new * 1e3:.0f} ms, safe grid 256 {safe * 1e3:.0f} ms, "
                f"model input {model * 1e3:.0f} ms, inflate r=6 {infl:.2f} s")
        if side == 2000:
            old = best_of(lambda: dense_planning_grid(m, 256), 1)
            assert np.array_equal(dense_planning_grid(m, 256), planning_grid(m, 256))
            line += f"; dense product before: {old:.2f} s"
        print(line)


def plan_office() -> None:
    import ndrql
    from ndrql.pipeline.settings import PlanSettings
    from ndrql.viz.maps import new_figure
    from ndrql.viz.plan import method_color, plot_plan

    m = office_plan()
    fig = new_figure(figsize=(11.0, 6.6), dpi=110)
    cases = (("the paper's grid (--grid area --size 50)", PlanSettings.paper(smooth=True, fallback="IQL")),
             ("the safe grid (default)", PlanSettings()))
    for i, (name, settings) in enumerate(cases):
        t = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rep = ndrql.solve(m, OFFICE_START, OFFICE_GOAL, "NDR-QL", 1, workers=1, settings=settings)
        total = time.perf_counter() - t
        r = rep.results[0]
        hits = len(r.route.final_collisions)
        print(f"{name}: grid {rep.grid.shape}, ran {r.method}, converged {r.converged}, {r.path_length} moves "
              f"({r.length_ratio:.3f} x A*), collisions {hits}, success {r.success}, grid path {r.route.grid_length:.0f} px, "
              f"final {r.route.length:.0f} px; stages " + ", ".join(f"{k} {v:.3f}" for k, v in rep.timings.items())
              + f"; total {total:.2f} s; prediction {rep.info.get('prediction_quality', {}).get('reasons')}")
        if rep.setup.auto is not None:
            a = rep.setup.auto
            print("  size auto: " + ", ".join(f"{t.size}: {'-' if t.ratio is None else f'{t.ratio:.3f}'}" for t in a.trials)
                  + f"; map's shortest {a.full_length:.0f} px")
        ax = fig.add_subplot(1, 2, i + 1)
        title = (f"{name}: {rep.grid.shape[0]}x{rep.grid.shape[1]} cells, {r.method}\n"
                 + (f"path crosses walls {hits} times: not a success" if hits else
                    f"collision-free, {r.route.length:,.0f} px after shortcutting"))
        cell = rep.grid.cell_size if rep.grid.cell_px is not None else None
        plot_plan(ax, m, rep.grid.blocked, OFFICE_START, OFFICE_GOAL, path=r.path, region=rep.region,
                  guideline=rep.guideline, label=r.method, color=method_color(r.method), title=title,
                  cell_size=cell, route=r.route)
    fig.tight_layout()
    from ndrql.io import save_figure

    print(f"wrote {save_figure(fig, ROOT / 'docs' / 'real-maps-office.png')}")


def write_ros_office() -> None:
    from PIL import Image

    from ndrql.io import write_text

    OUT.mkdir(parents=True, exist_ok=True)
    m = office_plan()
    Image.fromarray(np.where(m, 0, 254).astype(np.uint8)).save(OUT / "office.pgm")
    write_text(OUT / "office.yaml", "image: office.pgm\nresolution: 0.05\norigin: [-50.0, -50.0, 0.0]\nnegate: 0\n"
                                    "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    print(f"wrote {OUT / 'office.yaml'} and office.pgm (2000x2000, 5 cm per pixel)")


def main() -> int:
    downscale_timings()
    plan_office()
    write_ros_office()
    return 0


if __name__ == "__main__":
    sys.exit(main())
