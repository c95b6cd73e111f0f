"""Beyond the paper: Eq. 6's ties broken by the guideline and Eq. 7's region widened
(PriorConfig.guideline_ties, PriorConfig.region_dilation), checked against hand-computed values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ndrql.planning import priors as P
from ndrql.planning.config import MAX_TIES, PriorConfig
from ndrql.planning.methods import build_priors
from ndrql.planning.preset import load_preset

UP, DOWN, LEFT, RIGHT = range(4)
FREE = np.zeros((3, 3), dtype=bool)
GOAL = (0, 2)
ROWS, COLS = np.indices((3, 3))
MANH = (np.abs(ROWS - GOAL[0]) + np.abs(COLS - GOAL[1])).astype(float)  # the exact distance on a free grid
HYP = np.hypot(ROWS - GOAL[0], COLS - GOAL[1])
# a route up the left column, then along the top row: as short as any other from (2, 0)
ROUTE = np.array([[1.0, 1.0, 1.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])


def idx(r: int, c: int) -> int:
    return 3 * r + c


def test_widen_region_is_a_diamond_dilation():
    region = np.zeros((5, 5))
    region[2, 2] = 0.8
    region[0, 0] = 0.3
    assert np.array_equal(P.widen_region(region, 0), region)
    one = P.widen_region(region, 1)
    expected = np.zeros((5, 5))
    expected[[0, 0, 1], [0, 1, 0]] = 0.3
    expected[[2, 1, 3, 2, 2], [2, 2, 2, 1, 3]] = 0.8
    np.testing.assert_array_equal(one, expected)
    two = P.widen_region(region, 2)
    assert two[0, 2] == 0.8 and two[1, 1] == 0.8 and two[2, 0] == 0.8  # |dr| + |dc| <= 2 from the centre
    assert two[0, 1] == 0.3  # 3 moves from the centre, 1 from (0, 0)
    assert two[0, 0] == 0.3  # (0, 0) is 4 moves from the centre: only its own value


def test_route_nearness_is_the_blurred_guideline_scaled_to_one():
    near = P.route_nearness(ROUTE)
    assert near.max() == pytest.approx(1.0)
    assert near[0, 0] > near[1, 1] > 0.0  # on the route nearer than beside it
    assert not P.route_nearness(np.zeros((3, 3))).any()


def test_snapped_distance_ties_follow_the_route():
    near = P.route_nearness(ROUTE)
    got = P.snapped_distance(MANH, GOAL, near, 0.5)
    np.testing.assert_allclose(got, MANH + P.TIE_BREAK * HYP + 0.5 * (1.0 - near))
    np.testing.assert_allclose(P.snapped_distance(MANH, GOAL, near, 0.0), P.snapped_distance(MANH, GOAL))
    # neighbours whose distances differ keep their order: every step towards the goal stays lower
    for r in range(3):
        for c in range(3):
            for dr, dc in ((0, 1), (1, 0)):
                r2, c2 = r + dr, c + dc
                if r2 < 3 and c2 < 3 and MANH[r, c] != MANH[r2, c2]:
                    assert (got[r, c] < got[r2, c2]) == (MANH[r, c] < MANH[r2, c2])


def test_eq6_greedy_move_follows_the_guideline_among_equal_moves():
    """From (1, 0) up to (0, 0) and right to (1, 1) are both 2 moves from the goal: the straight line picks
    (1, 1), the route (0, 0)."""
    region = np.ones((3, 3))
    plain = build_priors("NDR-QL", FREE, (2, 0), GOAL, region, ROUTE, distance=MANH)
    assert plain.q0[idx(1, 0), RIGHT] > plain.q0[idx(1, 0), UP]
    cfg = PriorConfig(guideline_ties=0.5)
    tied = build_priors("NDR-QL", FREE, (2, 0), GOAL, region, ROUTE, cfg, distance=MANH)
    assert tied.q0[idx(1, 0), UP] > tied.q0[idx(1, 0), RIGHT]
    snapped = MANH + P.TIE_BREAK * HYP + 0.5 * (1.0 - P.route_nearness(ROUTE))
    assert tied.q0[idx(1, 0), UP] == pytest.approx(0.5 * math.exp(-snapped[0, 0]))
    # without a predicted distance (the paper's straight line) the option changes nothing
    assert np.array_equal(build_priors("NDR-QL", FREE, (2, 0), GOAL, region, ROUTE, cfg).q0,
                          build_priors("NDR-QL", FREE, (2, 0), GOAL, region, ROUTE).q0)


def test_eq7_threshold_on_the_widened_region():
    """Start and goal joined only through a cell the region misses: the paper's ladder finds no
    threshold; widened by one cell the gap takes its neighbours' 0.9 and the ladder stops at 0.89."""
    region = np.array([[0.9, 0.0, 0.9], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    with pytest.warns(P.ThresholdWarning):
        _, thd = P.ndr_qi(FREE, (0, 0), GOAL, region)
    assert thd is None
    q0, thd = P.ndr_qi(FREE, (0, 0), GOAL, region, PriorConfig(region_dilation=1))
    assert thd == pytest.approx(0.89)
    # (0, 0) right -> (0, 1), inside the widened region: MASK 0; down -> (1, 0): 0.9 too (widened)
    assert q0[idx(0, 0), RIGHT] == pytest.approx(0.5 * math.exp(-math.hypot(0, 1)))
    assert q0[idx(1, 1), DOWN] == pytest.approx(0.5 * -10 + 0.5 * math.exp(-math.hypot(2, 1)))


@pytest.mark.parametrize("kwargs, match", [
    ({"guideline_ties": MAX_TIES + 0.01}, "guideline_ties"), ({"guideline_ties": -0.1}, "guideline_ties"),
    ({"region_dilation": -1}, "region_dilation"), ({"region_dilation": 1.5}, "region_dilation"),
    ({"region_dilation": 11}, "region_dilation"),
])
def test_bad_values_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        PriorConfig(**kwargs)


def test_the_general_preset_sets_them_for_ndr_ql_only():
    preset = load_preset("general")
    _, p50 = preset.configs("NDR-QL", grid=50)
    _, p100 = preset.configs("NDR-QL", grid=100)
    assert (p50.region_dilation, p50.guideline_ties) == (1, 0.3)
    assert type(p50.region_dilation) is int and type(PriorConfig(region_dilation=2.0).region_dilation) is int
    assert (p100.region_dilation, p100.guideline_ties) == (0, 0.3)
    for method in ("IQL", "QL"):
        _, p = preset.configs(method, grid=50)
        assert (p.region_dilation, p.guideline_ties) == (0, 0.0)
    _, spec = load_preset("spec").configs("NDR-QL")
    assert (spec.region_dilation, spec.guideline_ties) == (0, 0.0)  # the paper's constants stay the paper's


def _greedy_route(q0: np.ndarray, blocked: np.ndarray, start, goal) -> list[tuple[int, int]]:
    """Cells the greedy action of ``q0`` visits from ``start`` until the goal or a cell it has seen."""
    from ndrql.planning import rules

    nxt, w = rules.next_table(blocked), blocked.shape[1]
    s, seen, route = start[0] * w + start[1], set(), [tuple(start)]
    while route[-1] != tuple(goal) and s not in seen:
        seen.add(s)
        s = int(nxt[s, int(np.argmax(q0[s]))])
        route.append(divmod(s, w))
    return route


def test_an_aisle_the_straight_line_prefers_corners_eq6_and_the_route_ties_do_not():
    """The warehouse case of docs/results.md in miniature: a shelf (row 1, columns 1-5) between two equally
    short routes from the top right to the bottom left, one along the top aisle and down the left end, one
    down the right corridor. The region covers the right corridor, the bottom row and one aisle cell
    beside the corridor; the exact distance ties the two routes."""
    from ndrql.maps.grid import bfs_distances

    blocked = np.zeros((3, 8), dtype=bool)
    blocked[1, 1:6] = True
    start, goal = (0, 7), (2, 0)
    dist = bfs_distances(blocked, goal).astype(float)
    assert dist[start] == 9 and dist[0, 6] == dist[1, 7] == 8  # both first moves are on a shortest route
    region = np.zeros((3, 8))
    region[:, 6:] = 1.0
    region[2, :] = 1.0
    region[0, 5] = 1.0
    guide = np.zeros((3, 8))
    guide[:, 7] = 1.0
    guide[2, :] = 1.0
    plain = build_priors("NDR-QL", blocked, start, goal, region, guide, distance=dist)
    route = _greedy_route(plain.q0, blocked, start, goal)
    # straight-line ties: along the aisle to (0, 5), where the only shorter move leaves the region and the
    # best action left is a bump into the shelf
    assert route[:3] == [(0, 7), (0, 6), (0, 5)] and route[-1] == (0, 5) and goal not in route
    tied = build_priors("NDR-QL", blocked, start, goal, region, guide, PriorConfig(guideline_ties=0.3), distance=dist)
    route = _greedy_route(tied.q0, blocked, start, goal)
    assert route[-1] == goal and len(route) - 1 == dist[start]  # down the corridor: a shortest route
    assert route[1] == (1, 7)
