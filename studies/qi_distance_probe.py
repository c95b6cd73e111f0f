"""Where does NDR-QL lose to IQL? A diagnostic: Eq. 6's distance term with the region's own geodesic distance.

NDR-QI (paper Eq. 6) initialises ``Q(s, a) = omega MASK(N_r(s')) + (1 - omega) exp(-dist(s', goal))`` with
the straight-line distance. This tool replaces only that distance by the number of 4-connected moves
from ``s'`` to the goal through free cells inside the predicted region (cells outside it: the moves
through all free cells plus 100), everything else unchanged (rewards, mask, threshold, constants of the
preset), and reports how often NDR-QL then beats IQL. A diagnostic, never a method: the geodesic
distance is a breadth-first search of the grid, a planner inside the planner, and IQL would deserve the
same; a large gain says that the straight-line tie-breaker, not the region, is what loses the maps.
Weights with a distance head add a row with their own predicted distance in Eq. 6 (a method: no search).

    python studies/qi_distance_probe.py --grid 50          # the 'select' set, 20 maps per family, 10 seeds
"""

from __future__ import annotations

import math

import numpy as np

from ndrql.experiments.transfer import row_configs
from ndrql.maps.grid import bfs_distances
from ndrql.model.predict import Predictor
from ndrql.model.weights import resolve_weights
from ndrql.planning import priors as P
from ndrql.planning.methods import Priors, build_priors
from ndrql.planning.runner import run_plan
from win_share_search import cases_of, probe_parser, probe_preset, reference_runs

#: Moves added outside the region, so that a path through it is always preferred.
OUTSIDE = 100


def geodesic_q0(blocked: np.ndarray, goal: tuple[int, int], region: np.ndarray, thd: float | None,
                cfg) -> np.ndarray:
    """Eq. 6 with ``dist`` = 4-connected moves to the goal inside the region (module docstring)."""
    blocked = np.asarray(blocked, bool)
    inside = blocked | ~(np.asarray(region) > (thd if thd is not None else -1.0))
    d_in = bfs_distances(inside, goal).astype(float)
    d_all = bfs_distances(blocked, goal).astype(float)
    dist = np.where(d_in >= 0, d_in, np.where(d_all >= 0, d_all + OUTSIDE, 1e6))
    r2, c2 = P._next_cells(blocked)
    return P.ndr_qi_mask_term(blocked, region, thd, cfg) + (1.0 - cfg.omega_qi) * np.exp(-dist[r2, c2])


def main() -> None:
    args = probe_parser(__doc__, symmetries=1).parse_args()

    predictor = Predictor.load(resolve_weights(args.weights), threads=1, backend="torch", symmetries=args.symmetries)
    preset = probe_preset(args)
    seeds = list(range(args.seeds))
    cases = cases_of(args.set, args.grid, args.per_family, predictor)
    ref = reference_runs(cases, preset, seeds)
    learned = predictor.predict_grid_all(np.zeros((2, 2), bool), (0, 0), (1, 1))[2] is not None
    names = ["Eq. 6 (straight line)"] + (["Eq. 6 (the model's distance)"] if learned else []) + ["Eq. 6 (geodesic in the region)"]
    rows: dict[str, list[tuple[float, float]]] = {name: [] for name in names}
    for (fam, case, (region, guide, *_)), iql in zip(cases, ref):
        ql, pc = row_configs(preset, grid=case.n)["NDR-QL (model)"]
        paper = build_priors("NDR-QL", case.blocked, case.start_cell, case.goal_cell, region, guide, pc)
        geo = Priors(paper.r_c, geodesic_q0(case.blocked, case.goal_cell, region, paper.threshold, pc), paper.threshold)
        variants = [paper, geo]
        if learned:
            d = predictor.predict_cells(case.blocked, case.start_cell, case.goal_cell)[2]
            variants.insert(1, build_priors("NDR-QL", case.blocked, case.start_cell, case.goal_cell, region, guide, pc, distance=d))
        for name, pri in zip(rows, variants):
            rs = [run_plan(case.blocked, case.start_cell, case.goal_cell, "NDR-QL", s, ql, pc, priors=pri) for s in seeds]
            steps = np.mean([r.convergence_steps if r.converged else r.total_steps for r in rs])
            ratio = np.mean([r.length_ratio for r in rs if r.converged and r.length_ratio is not None] or [math.nan])
            rows[name].append((steps, ratio, iql[:, 0].mean()))
    print(f"{args.set}, grid {args.grid}, weights {args.weights}, preset {args.preset}, symmetries {args.symmetries}: "
          f"{len(cases)} maps x {len(seeds)} seeds\n")
    print("| NDR-QI distance term | beats IQL | geometric mean of steps (IQL's) | path / A* |\n|---|---:|---:|---:|")
    for name, vals in rows.items():
        a = np.array(vals)
        print(f"| {name} | {100 * np.mean(a[:, 0] < a[:, 2]):.0f}% | {math.exp(np.mean(np.log(a[:, 0]))):,.0f} "
              f"({math.exp(np.mean(np.log(a[:, 2]))):,.0f}) | {np.nanmean(a[:, 1]):.3f} |")


if __name__ == "__main__":
    main()
