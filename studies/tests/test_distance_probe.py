"""studies/distance_probe.py: its measures of a distance field on hand-made grids."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

from ndrql.maps.grid import bfs_distances


@pytest.fixture(scope="module")
def probe():
    return importlib.import_module("distance_probe")


def _grid() -> tuple[np.ndarray, tuple[int, int], np.ndarray]:
    # 4 x 5 cells, a wall in column 2 open only at the bottom row; goal top right
    blocked = np.zeros((4, 5), dtype=bool)
    blocked[:3, 2] = True
    goal = (0, 4)
    return blocked, goal, bfs_distances(blocked, goal).astype(float)


def test_the_exact_distances_order_every_pair_and_lead_the_greedy_route_home(probe):
    blocked, goal, truth = _grid()
    ok = ~blocked
    right, total = probe.neighbour_order(truth, truth, ok)
    assert right == total == 22  # free neighbour pairs: 10 along rows (2 + 2 + 2 + 4), 12 along columns (3 x 4)
    assert probe.greedy_route(truth, blocked, (0, 0), goal) == int(truth[0, 0]) == 10


def test_a_pit_stops_the_greedy_route_and_misorders_its_pairs(probe):
    blocked, goal, truth = _grid()
    field = truth.copy()
    field[0, 0] = -1.0  # the start looks nearer than anything around it: a pit
    assert probe.greedy_route(field, blocked, (1, 0), goal) is None  # goes to (0, 0), then back: a revisit
    right, total = probe.neighbour_order(field, truth, ~blocked)
    assert (right, total) == (20, 22)  # (0,0)-(0,1) and (0,0)-(1,0) now point the wrong way
    low, move = probe.lowest_neighbour(field, blocked)
    assert low[1, 0] == -1.0 and probe.MOVES[int(move[1, 0])] == (-1, 0)
    assert np.isinf(probe.lowest_neighbour(field, np.ones_like(blocked))[0]).all()  # no free neighbour: inf
