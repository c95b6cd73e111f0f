"""What merging cells does to the route: the merged grid's own shortest path against the planning grid's.

A view that merges cells (``coarse``, ``walls``; :mod:`ndrql.dataset.views`) shows the model a smaller
grid, and the model draws that grid's route. This measures, per map of a development set and per merge
rule, how far that route is from the real one, with no model at all: the merged grid's 4-connected
shortest path (times the merge factor) over the planning grid's, and the share of the planning grid's
shortest path that lies within 2 cells of the merged path's cells (*recall*). A merge whose own route
misses the real one misleads even a perfect model of the merged grid::

    PYTHONPATH=src python studies/large_view/merge_routes.py --set large-dev-256 --grid 256 --factor 2

Development sets only (a sealed set is refused); prints one line per family and the pooled recall.
"""
from __future__ import annotations

import argparse
from collections import defaultdict

import numpy as np
from scipy import ndimage

from ndrql.dataset.render import merge_cells, merge_walls
from ndrql.errors import NoPathError
from ndrql.experiments.ceiling import grid_case
from ndrql.experiments.transfer import eval_set, eval_spec
from ndrql.maps.astar import astar4

Cell = tuple[int, int]


def route_recall(blocked: np.ndarray, start: Cell, goal: Cell, merged: np.ndarray, f: int) -> tuple[float, float] | None:
    """(merged route length x ``f`` / real length, share of the real route within 2 cells of the merged
    route's free cells), or ``None`` when start and goal do not connect on ``merged``."""
    real = astar4(blocked, start, goal)
    try:
        seen = astar4(merged, (start[0] // f, start[1] // f), (goal[0] // f, goal[1] // f))
    except NoPathError:
        return None
    on_real = np.zeros(blocked.shape, bool)
    on_real[tuple(np.array(real.path).T)] = True
    near = np.zeros(blocked.shape, bool)
    for r, c in seen.path:
        near[f * r:f * r + f, f * c:f * c + f] = True
    near = ndimage.binary_dilation(near & ~blocked, iterations=2)
    return f * seen.moves / max(real.moves, 1), float(on_real[near].sum() / on_real.sum())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", default="large-dev-256")
    ap.add_argument("--grid", type=int, default=256)
    ap.add_argument("--factor", type=int, default=2, help="cells merged along each side")
    args = ap.parse_args(argv)
    spec = eval_spec(args.set)
    if spec.seed >= 950_000:
        raise SystemExit(f"{args.set} is a sealed set: only the release report evaluates on it")
    gs = eval_set(spec, progress=False)
    rows: dict[str, dict[str, list]] = defaultdict(lambda: {"coarse": [], "walls": [], "walls_closed": []})
    for i in range(len(gs)):
        raw, fam = gs.raw(i), str(gs.families[i])
        case = grid_case(f"{fam}-{i}", fam, raw.obstacles, raw.start, raw.goal, args.grid)
        if case is None:
            continue
        b, s, g = case.blocked, tuple(case.start_cell), tuple(case.goal_cell)
        rows[fam]["coarse"].append(route_recall(b, s, g, merge_cells(b, args.factor), args.factor))
        walls = merge_walls(b, args.factor, s, g)
        fell_back = np.array_equal(walls, merge_cells(b, args.factor))
        rows[fam]["walls_closed"].append(fell_back)
        rows[fam]["walls"].append(route_recall(b, s, g, walls, args.factor))
    print("| family | maps | coarse: route length / real | coarse: recall | walls: maps it keeps connected | walls: recall |")
    print("|---|---:|---:|---:|---:|---:|")
    pooled = {"coarse": [], "walls": []}
    for fam in sorted(rows):
        r = rows[fam]
        co = np.array([x for x in r["coarse"] if x is not None])
        wa = np.array([x for x in r["walls"] if x is not None])
        kept = sum(not c for c in r["walls_closed"])
        pooled["coarse"] += list(co[:, 1])
        pooled["walls"] += list(wa[:, 1])
        print(f"| {fam} | {len(r['coarse'])} | {co[:, 0].mean():.2f} | {co[:, 1].mean():.2f} | {kept} | {wa[:, 1].mean():.2f} |")
    print(f"\npooled recall: coarse {np.mean(pooled['coarse']):.2f}, walls {np.mean(pooled['walls']):.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
