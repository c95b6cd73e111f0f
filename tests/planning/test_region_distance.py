"""Beyond the paper: Eq. 6's distance counted through the thresholded region (PriorConfig.region_distance),
checked against hand-counted moves; the paper's setting (0) stays exactly what it was."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ndrql.errors import NdrqlError
from ndrql.maps.grid import bfs_distances
from ndrql.planning import priors as P
from ndrql.planning.config import PriorConfig
from ndrql.planning.methods import build_priors
from ndrql.planning.preset import load_preset

UP, DOWN, LEFT, RIGHT = range(4)

# A 5 x 5 grid with a wall across row 2 but for a gap at (2, 4). Start (4, 0), goal (0, 0).
#   row 0: G . . . .
#   row 1: . . . . .
#   row 2: # # # # .
#   row 3: . . . . .
#   row 4: S . . . .
BLOCKED = np.zeros((5, 5), dtype=bool)
BLOCKED[2, :4] = True
START, GOAL = (4, 0), (0, 0)
# The region: the route round the gap (bottom row, right column, top row), 0.9; everything else 0.2.
REGION = np.full((5, 5), 0.2)
REGION[4, :] = 0.9
REGION[:, 4] = 0.9
REGION[0, :] = 0.9


def _greedy(q0: np.ndarray, start: tuple[int, int], goal: tuple[int, int], limit: int = 30) -> list[tuple[int, int]]:
    """Cells the greedy policy of ``q0`` visits from ``start`` (stops at the goal, a repeat or ``limit``)."""
    moves = {UP: (-1, 0), DOWN: (1, 0), LEFT: (0, -1), RIGHT: (0, 1)}
    route, cell = [start], start
    for _ in range(limit):
        a = int(np.argmax(q0[cell[0] * 5 + cell[1]]))
        nxt = (cell[0] + moves[a][0], cell[1] + moves[a][1])
        if not (0 <= nxt[0] < 5 and 0 <= nxt[1] < 5) or BLOCKED[nxt]:
            nxt = cell
        if nxt in route:
            break
        route.append(nxt)
        cell = nxt
        if cell == goal:
            break
    return route


def test_region_distance_counts_moves_through_the_region():
    d = P.region_distance(BLOCKED, REGION, 0.5, GOAL)
    # inside the region: moves along the top row, down the right column, along the bottom row
    assert [d[0, c] for c in range(5)] == [0, 1, 2, 3, 4]
    assert [d[r, 4] for r in range(5)] == [4, 5, 6, 7, 8]
    assert [d[4, c] for c in range(5)] == [12, 11, 10, 9, 8]
    # outside the region: the straight line (no distance given), or the given distance
    assert d[1, 0] == pytest.approx(1.0) and d[3, 1] == pytest.approx(np.hypot(3, 1))
    given = np.full((5, 5), 42.0)
    d2 = P.region_distance(BLOCKED, REGION, 0.5, GOAL, given)
    assert d2[1, 0] == 42.0 and d2[3, 1] == 42.0 and d2[4, 0] == 12.0
    assert d2.dtype == np.float64 and d2.shape == (5, 5)


def test_goal_outside_the_region_leaves_the_given_distance():
    region = REGION.copy()
    region[0, 0] = 0.1
    given = np.arange(25, dtype=float).reshape(5, 5)
    np.testing.assert_array_equal(P.region_distance(BLOCKED, region, 0.5, GOAL, given), given)


def test_ndr_qi_with_region_distance_follows_the_region_round_the_wall():
    # A predicted distance that promises a way straight up through the wall (the Manhattan distance):
    # its greedy policy from the start runs into the wall; counted through the region it goes round.
    rows, cols = np.indices((5, 5))
    manhattan = (np.abs(rows - GOAL[0]) + np.abs(cols - GOAL[1])).astype(float)
    cfg = PriorConfig(omega_qi=0.5)
    plain, thd = P.ndr_qi(BLOCKED, START, GOAL, REGION, cfg, distance=manhattan)
    assert thd == pytest.approx(0.89)  # the paper's schedule: 0.99, 0.98, ... the first that connects
    assert _greedy(plain, START, GOAL)[-1] != GOAL
    through, thd2 = P.ndr_qi(BLOCKED, START, GOAL, REGION, PriorConfig(omega_qi=0.5, region_distance=1),
                             distance=manhattan)
    assert thd2 == thd
    route = _greedy(through, START, GOAL)
    assert route[-1] == GOAL and len(route) - 1 == 12  # the only way round: 12 moves


def test_region_distance_0_is_the_paper_bit_for_bit():
    rows, cols = np.indices((5, 5))
    dist = (np.abs(rows) + np.abs(cols)).astype(float) + 0.3
    for distance in (None, dist):
        a = build_priors("NDR-QL", BLOCKED, START, GOAL, REGION, REGION, PriorConfig(), distance=distance)
        b = build_priors("NDR-QL", BLOCKED, START, GOAL, REGION, REGION, PriorConfig(region_distance=0),
                         distance=distance)
        np.testing.assert_array_equal(a.q0, b.q0)
        np.testing.assert_array_equal(a.r_c, b.r_c)


def test_no_threshold_means_no_region_distance():
    # a region that never connects start and goal: the mask is 0 and the distance term is the given one
    region = np.zeros((5, 5))
    with pytest.warns(P.ThresholdWarning):
        q_a, thd = P.ndr_qi(BLOCKED, START, GOAL, region, PriorConfig(), distance=np.ones((5, 5)))
    with pytest.warns(P.ThresholdWarning):
        q_b, _ = P.ndr_qi(BLOCKED, START, GOAL, region, PriorConfig(region_distance=1), distance=np.ones((5, 5)))
    assert thd is None
    np.testing.assert_array_equal(q_a, q_b)


@pytest.mark.parametrize("bad", [2, -1, 0.5, "yes", float("nan")])
def test_region_distance_must_be_0_or_1(bad):
    with pytest.raises(ValueError, match="region_distance"):
        PriorConfig(region_distance=bad)


def test_a_preset_file_value_of_1_0_is_1():
    assert PriorConfig(region_distance=1.0).region_distance == 1
    assert isinstance(PriorConfig(region_distance=1.0).region_distance, int)


def test_requests_and_presets_take_it(tmp_path):
    import ndrql

    grid = np.zeros((20, 20), dtype=bool)
    req = ndrql.build_request(grid, (1, 1), (18, 18), preset="general", priors={"region_distance": 1})
    assert all(req.constants("NDR-QL", n)[1].region_distance == 1 for n in (16, 50, 100, 200))
    with pytest.raises(NdrqlError, match="region_distance"):
        ndrql.build_request(grid, (1, 1), (18, 18), preset="general", priors={"region_distance": 3})
    spec = load_preset("spec")
    assert spec.configs("NDR-QL", grid=50)[1].region_distance == 0  # the paper's constants stay the paper's


# --- properties on random grids (Hypothesis) ---------------------------------------------------------------


@st.composite
def _grids(draw):
    h, w = draw(st.integers(3, 12)), draw(st.integers(3, 12))
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    blocked = rng.random((h, w)) < draw(st.floats(0.0, 0.4))
    region = rng.random((h, w))
    goal = (int(rng.integers(h)), int(rng.integers(w)))
    blocked[goal] = False
    return blocked, region, goal, draw(st.floats(0.0, 0.95))


@settings(max_examples=200, deadline=None)
@given(_grids())
def test_region_distance_is_the_bfs_of_the_region_where_it_reaches(case):
    blocked, region, goal, thd = case
    other = np.full(blocked.shape, 1000.0)
    d = P.region_distance(blocked, region, thd, goal, other)
    free = bfs_distances(blocked, goal)
    inside = bfs_distances(blocked | ~(region > thd), goal)
    reached = inside >= 0
    # where the region reaches the goal: its own move count, never below the free grid's
    np.testing.assert_array_equal(d[reached], inside[reached])
    assert np.all(d[reached] >= free[reached])
    # elsewhere: the given distance, untouched
    assert np.all(d[~reached] == 1000.0)
    # a region over every cell is the free grid's BFS distance
    full = P.region_distance(blocked, np.ones_like(region), thd, goal, other)
    np.testing.assert_array_equal(full[free >= 0], free[free >= 0])
