"""NDR-QL's in-process work on known maps against IQL-BFS's, as the release and transfer reports measure it, for
today's priors and for the reference path (the numpy drawing and blur), side by side in one run.

Per case, as :func:`ndrql.experiments.transfer.collect` and :func:`ndrql.experiments.transfer_floors.work_seconds`
measure it: NDR-QL's work is plan's exact source (:func:`ndrql.pipeline.sources.drawn_priors`, least of three calls)
plus the judge's verdict on it plus the NDR-QL row's run (priors and learning, mean over seeds); IQL-BFS's is its
row's run. Each row takes the constants of the ``general`` preset at the case's grid, as ``reproduce release`` does.
The reference path swaps back what issue 53 replaced (:func:`reference_path`) for the same cases, interleaved with
today's, so both see the same load; the priors of both are checked to be the same bits. Development maps only (a set's maps are generated in memory
from its registered spec; sealed sets are refused).

    python benchmarks/prior_work.py --grids 50,100 --maps 24
    python benchmarks/prior_work.py --grids 128 --set large-dev-128 --maps 12
"""

from __future__ import annotations

import argparse
import contextlib
import time
import warnings

import numpy as np

from ndrql.experiments.ceiling import grid_case, larger_sizes
from ndrql.experiments.eval_sets import eval_spec
from ndrql.experiments.transfer import BFS_ROW, row_configs
from ndrql.maps import route_cells
from ndrql.maps.astar import shortest_path8
from ndrql.maps.grid import bfs_distances
from ndrql.pipeline import sources
from ndrql.pipeline.judge import judge
from ndrql.planning import priors
from ndrql.planning.preset import load_preset
from ndrql.planning.runner import astar_length, run_plan
from ndrql.synth import labels
from ndrql.synth.generate import generate_sample

ORACLE = "NDR-QL (oracle)"


def _far_field(blocked: np.ndarray, goal: tuple[int, int]) -> np.ndarray:
    """``exact_distance_field`` as it was: the far term over ``np.indices`` of the whole grid."""
    d = bfs_distances(np.asarray(blocked, bool), goal).astype(np.float64)
    if (d < 0).any():
        rows, cols = np.indices(d.shape)
        far = (d.max() if (d >= 0).any() else 0.0) + np.abs(rows - goal[0]) + np.abs(cols - goal[1])
        d = np.where(d < 0, far, d)
    return d


def _path_cells(blocked, start, goal) -> np.ndarray:
    """The A*'s path as it reached the drawing before: a list of tuples, then an array."""
    return np.asarray(shortest_path8(blocked, start, goal).path, dtype=np.int64).reshape(-1, 2)


@contextlib.contextmanager
def reference_path():
    """The exact source and Eq. 6's priors as they ran before issue 53's kernels: the numpy drawing, far field, blur
    and tie-break, the A*'s path through a list, and the schedule, straight line and blur weights computed per call
    (the C A*'s open list stays today's)."""
    names = ((sources, "route_cells", route_cells.route_cells_numpy), (sources, "exact_distance_field", _far_field),
             (priors, "c_kernels", lambda: None), (labels, "shortest_path8_cells", _path_cells),
             (priors, "_schedule", priors._schedule.__wrapped__),
             (priors, "_straight_field", priors._straight_field.__wrapped__),
             (priors, "_gauss_weights", priors._gauss_weights.__wrapped__))
    saved = [(mod, name, getattr(mod, name)) for mod, name, _ in names]
    for mod, name, value in names:
        setattr(mod, name, value)
    try:
        yield
    finally:
        for mod, name, value in saved:
            setattr(mod, name, value)


def ndr_work(case, cfgs, seeds: list[int], opt: int) -> tuple[float, object]:
    """The exact source (least of 3) + the judge + the NDR-QL row's run (mean over seeds), and the priors drawn."""
    b, s, g = case.blocked, case.start_cell, case.goal_cell
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        pr = sources.drawn_priors("oracle", b, s, g, None)
        best = min(best, time.perf_counter() - t0)
    ql, pc = cfgs[ORACLE]
    shortest = int(bfs_distances(b, g)[tuple(s)])
    t0 = time.perf_counter()
    judge(pr.region, pr.guideline, b, s, g, pc, shortest)
    judged = time.perf_counter() - t0
    runs = [run_plan(b, s, g, "NDR-QL", seed, ql, pc, pr.region, pr.guideline, distance=pr.distance, astar=opt)
            for seed in seeds]
    return best + judged + float(np.mean([r.wall_time for r in runs])), (pr, runs[0].threshold)


def bfs_work(case, cfgs, seeds: list[int], opt: int) -> float:
    ql, pc = cfgs[BFS_ROW]
    return float(np.mean([run_plan(case.blocked, case.start_cell, case.goal_cell, "IQL-BFS", seed, ql, pc,
                                   astar=opt).wall_time for seed in seeds]))


def same_bits(a, b) -> bool:
    (pa, ta), (pb, tb) = a, b
    return ta == tb and all(x.tobytes() == y.tobytes() for x, y in
                            ((pa.region, pb.region), (pa.guideline, pb.guideline), (pa.distance, pb.distance)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--grids", default="50,100", help="planning grids (cells), comma-separated")
    ap.add_argument("--set", default="transfer", help="a development set of transfer_sets.json")
    ap.add_argument("--maps", type=int, default=24, help="planned maps per grid")
    ap.add_argument("--seeds", type=int, default=3, help="runs per row and map (mean, as the reports take it)")
    a = ap.parse_args()
    spec, preset, seeds = eval_spec(a.set), load_preset("general"), list(range(a.seeds))
    warnings.simplefilter("ignore")
    for n in (int(x) for x in a.grids.split(",")):
        new, ref, base, sides, i = [], [], [], [], 0
        while len(base) < a.maps and i < 20 * a.maps:
            raw = generate_sample(spec, i)
            i += 1
            case = grid_case(f"{a.set}-{i}", "", raw.obstacles, raw.start, raw.goal, n, larger_sizes(n))
            if case is None:
                continue
            cfgs = row_configs(preset, grid=case.n)
            opt = astar_length(case.blocked, case.start_cell, case.goal_cell)
            ndr_work(case, cfgs, seeds[:1], opt)  # warm caches of this grid's size
            w_new, p_new = ndr_work(case, cfgs, seeds, opt)
            with reference_path():
                w_ref, p_ref = ndr_work(case, cfgs, seeds, opt)
            if not same_bits(p_new, p_ref):
                raise SystemExit(f"{case.name}: the priors differ from the reference path's")
            new.append(w_new)
            ref.append(w_ref)
            base.append(bfs_work(case, cfgs, seeds, opt))
            sides.append(case.n)
        r_new = np.median(np.array(new) / np.array(base))
        r_ref = np.median(np.array(ref) / np.array(base))
        print(f"grid {n} ({a.set}, {len(base)} maps, planned on {min(sides)}-{max(sides)} cells): NDR-QL work / "
              f"IQL-BFS work, median: reference path {r_ref:.2f}x, today {r_new:.2f}x; medians in ms: IQL-BFS "
              f"{1e3 * np.median(base):.2f}, NDR-QL reference {1e3 * np.median(ref):.2f}, today "
              f"{1e3 * np.median(new):.2f}; priors the same bits on every map")


if __name__ == "__main__":
    main()
