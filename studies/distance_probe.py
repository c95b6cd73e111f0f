"""How good is the distance head where the planner looks? Its order of neighbours as Eq. 6 takes it.

Eq. 6 (NDR-QI) initialises ``Q(s, a)`` with ``exp(-dist(s', goal))``, the model's distance snapped to
Manhattan plus an even detour (``planning.priors.snapped_distance``), so what counts is how that
snapped field orders the cells around each state, not the raw output. On the planning grid of each
map of ``select`` (never the reported set), against the exact 4-connected distances of the cells that
reach the goal, this prints per family and overall:

- **raw / snapped order**: the share of pairs of neighbouring cells whose distances the model orders
  as the truth does, before and after the snap (``order_accuracy`` of training validation, per cell);
- **greedy move right**: the share of cells whose lowest free neighbour (snapped) is truly nearer;
- **pits**: cells (not the goal) whose free neighbours all look at least as far (snapped): a greedy
  policy stops there and Q-learning must unlearn the prior around it; per map, mean;
- **greedy reaches**: the share of maps on which always taking the lowest neighbour from the start
  reaches the goal (without revisiting a cell), and its moves over the shortest path's on those maps.

    python studies/distance_probe.py --grid 50                       # the shipped weights (~1 min)
    python studies/distance_probe.py --grid 50 --weights FILE        # a candidate
"""

from __future__ import annotations

import numpy as np

from ndrql.experiments.ceiling import oracle_priors
from ndrql.model.predict import Predictor
from ndrql.model.symmetry import DEFAULT_COUNT
from ndrql.model.weights import resolve_weights
from ndrql.planning.priors import snapped_distance
from ndrql.training.evaluate import order_accuracy
from win_share_search import cases_of, probe_parser

#: The four moves of the planner (4-connected).
MOVES = ((-1, 0), (1, 0), (0, -1), (0, 1))


def neighbour_order(field: np.ndarray, truth: np.ndarray, ok: np.ndarray) -> tuple[int, int]:
    """Pairs of neighbouring cells, both ``ok``, that ``field`` orders as ``truth``: (right, total)
    (training validation's :func:`~ndrql.training.evaluate.order_accuracy`, one cell apart)."""
    return order_accuracy(field, np.where(ok, truth, -1.0), step=1)


def lowest_neighbour(field: np.ndarray, blocked: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per cell, the value and the index (into :data:`MOVES`) of its lowest free neighbour (inf: none)."""
    h, w = field.shape
    pad = np.pad(np.where(blocked, np.inf, field), 1, constant_values=np.inf)
    stack = np.stack([pad[1 + dr:1 + dr + h, 1 + dc:1 + dc + w] for dr, dc in MOVES])
    return stack.min(0), stack.argmin(0)


def greedy_route(field: np.ndarray, blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> int | None:
    """Moves of the route that always takes the lowest free neighbour from ``start``; ``None`` when it
    revisits a cell (a pit or a loop) before the goal."""
    _, move = lowest_neighbour(field, blocked)
    cur, seen = tuple(start), {tuple(start)}
    while cur != tuple(goal):
        dr, dc = MOVES[int(move[cur])]
        cur = (cur[0] + dr, cur[1] + dc)
        if cur in seen:
            return None
        seen.add(cur)
    return len(seen) - 1


def probe(case, distance: np.ndarray) -> dict[str, object]:
    """The measures of the module docstring for one map (``distance``: the model's, cells)."""
    blocked, goal = case.blocked, tuple(case.goal_cell)
    truth = oracle_priors(case, distance=True)[2]
    reach = ~blocked & (truth < truth.max())
    snap = snapped_distance(distance, goal)
    low, move = lowest_neighbour(snap, blocked)
    cells = reach.copy()
    cells[goal] = False
    rows, cols = np.nonzero(cells)
    dr = np.array([m[0] for m in MOVES])[move[rows, cols]]
    dc = np.array([m[1] for m in MOVES])[move[rows, cols]]
    picked = truth[rows + dr, cols + dc]
    route = greedy_route(snap, blocked, case.start_cell, goal)
    return {"raw": neighbour_order(distance, truth, reach), "snapped": neighbour_order(snap, truth, reach),
            "move": (int((picked < truth[rows, cols]).sum()), len(rows)),
            "pits": int((low[rows, cols] >= snap[rows, cols]).sum()),
            "reaches": route is not None,
            "ratio": route / truth[tuple(case.start_cell)] if route is not None else np.nan}


def main() -> None:
    args = probe_parser(__doc__, symmetries=DEFAULT_COUNT).parse_args()
    predictor = Predictor.load(resolve_weights(args.weights), threads=1, backend="torch", symmetries=args.symmetries)
    cases = cases_of(args.set, args.grid, args.per_family, predictor)
    if any(len(pr) < 3 for _, _, pr in cases):
        raise SystemExit(f"{args.weights} has no distance head: nothing to probe")
    results: dict[str, list[dict]] = {}
    for fam, case, pr in cases:
        results.setdefault(fam, []).append(probe(case, np.asarray(pr[2])))
    print(f"{args.set}, grid {args.grid}: {len(cases)} maps, weights {args.weights}, {args.symmetries} orientations")
    print("| family | maps | raw order | snapped order | greedy move right | pits per map | greedy reaches | its moves / shortest |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for fam, rs in [*results.items(), ("all", [r for rs in results.values() for r in rs])]:
        share = {k: 100 * sum(r[k][0] for r in rs) / max(sum(r[k][1] for r in rs), 1) for k in ("raw", "snapped", "move")}
        ratios = [r["ratio"] for r in rs if r["reaches"]]
        print(f"| {fam} | {len(rs)} | {share['raw']:.1f}% | {share['snapped']:.1f}% | {share['move']:.1f}% | "
              f"{np.mean([r['pits'] for r in rs]):.1f} | {100 * np.mean([r['reaches'] for r in rs]):.0f}% | "
              f"{np.mean(ratios) if ratios else float('nan'):.3f} |")


if __name__ == "__main__":
    main()
