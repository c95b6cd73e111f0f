"""``--size auto`` (ndrql.maps.sizing) on maps drawn in code: every connected start/goal pair gets a grid,
else the error names the passage that is too narrow, in pixels and metres, and what to pass.

The maps are hand-made analogues of public benchmark maps (MovingAI-like mazes with 1-2 cell corridors
at 128-512 px, rooms, game-like caves; ROS-like offices at 0.05-0.1 m with doors and unknown space),
drawn from a seed by :mod:`ndrql.synth.drawn`; no public map is read.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from ndrql.errors import NoPathError
from ndrql.limits import MAX_GRID_SIZE
from ndrql.maps.grid import GridMap
from ndrql.maps.sizing import choose_size, connected4, full_route, size_to_open
from ndrql.pipeline.problem import build_grid
from ndrql.pipeline.settings import PlanSettings
from ndrql.synth.drawn import cave, connected, free_pairs, maze, ros_office, rooms


def check_plannable(grid_map: GridMap, pairs) -> int:
    """Every connected pair gets a safe grid whose start and goal cells are connected; returns how many were."""
    planned = 0
    for s, g in pairs:
        if not connected(grid_map.obstacles, s, g):
            continue
        try:
            with warnings.catch_warnings(record=True):  # snapped points, slow or own-pixel grids: told, not failed
                warnings.simplefilter("always")
                pg, setup = build_grid(grid_map, s, g, PlanSettings())
        except NoPathError as exc:  # only when not even the map's own pixels are within the limits
            assert max(grid_map.shape) > MAX_GRID_SIZE and "passage at pixel" in str(exc), str(exc)
            continue
        assert pg.start == pg.goal or connected4(pg.blocked, pg.start, pg.goal), (s, g, setup.size)
        planned += 1
    return planned


@pytest.mark.parametrize("cells, corridor, wall", [(32, 2, 2), (42, 2, 1), (64, 1, 1), (85, 2, 1), (128, 2, 2)])
def test_mazes_with_one_and_two_pixel_corridors_get_a_grid(cells, corridor, wall):
    occ = maze(cells, corridor, wall, seed=cells)
    assert 127 <= occ.shape[0] <= 514
    grid_map = GridMap(occ, source="drawn maze")
    corner = (wall, wall)
    far = (occ.shape[0] - wall - 1, occ.shape[1] - wall - 1)
    assert check_plannable(grid_map, [(corner, far), *free_pairs(occ, 3, seed=1)]) >= 1


def test_the_issue_maze_no_longer_says_no_free_cell():
    # 2 px corridors between 1 px walls at 127 px: every size below 127 blocks every cell
    occ = maze(42, 2, 1, seed=0)
    route = full_route(occ, (1, 1), (125, 125))
    choice = choose_size(occ, (1, 1), (125, 125), route.cost, 512)
    assert choice.size == 127 and choice.within_tolerance and not choice.own_pixels
    assert all(t.grid_length is None for t in choice.trials[:-1])


@pytest.mark.parametrize("kind", ["rooms-2", "rooms-1", "cave"])
def test_rooms_and_caves(kind):
    occ = rooms(300, 60, int(kind[-1]), seed=3) if kind.startswith("rooms") else cave(256, seed=4)
    assert check_plannable(GridMap(occ, source=kind), free_pairs(occ, 6, seed=2)) >= 1


@pytest.mark.parametrize("h, w, resolution, door_m", [(400, 600, 0.1, 0.8), (700, 900, 0.05, 0.8), (300, 500, 0.1, 0.1)])
def test_ros_offices_with_doors_and_unknown_space(h, w, resolution, door_m):
    grid_map = ros_office(h, w, resolution, door_m, seed=5)
    assert check_plannable(grid_map, free_pairs(grid_map.obstacles, 5, seed=6)) >= 1


def test_a_one_pixel_door_beyond_max_size_plans_on_the_maps_own_pixels():
    occ = np.zeros((400, 600), dtype=bool)
    occ[:, 300] = True
    occ[200, 300] = False  # a 1 px gap
    route = full_route(occ, (100, 100), (300, 500))
    choice = choose_size(occ, (100, 100), (300, 500), route.cost, 512)
    assert choice.own_pixels and choice.size == 600 and choice.chosen.ratio == pytest.approx(1.0)
    with warnings.catch_warnings(record=True) as told:
        warnings.simplefilter("always")
        pg, setup = build_grid(GridMap(occ, source="gap"), (100, 100), (300, 500), PlanSettings())
    assert pg.shape == (400, 600) and setup.auto.own_pixels
    said = [str(w.message) for w in told]
    assert any("planning on the map's own pixels (600 cells" in m for m in said), said
    assert any("Q-learning may take minutes" in m for m in said), said  # and that it is a large grid


def test_too_narrow_beyond_the_limit_names_the_passage_in_pixels_and_metres():
    occ = np.zeros((300, 1200), dtype=bool)
    occ[:, 600] = True
    occ[150, 600] = False  # 1 px = 5 cm: no grid up to 512 cells keeps it, and 1200 px is over the limit
    grid_map = GridMap(occ, source="wide", resolution=0.05, origin=(0.0, 0.0, 0.0))
    with pytest.raises(NoPathError) as err:
        build_grid(grid_map, (100, 100), (100, 1100), PlanSettings())
    msg = str(err.value)
    assert "passage at pixel (150, 600) is about 1 px = 0.05 m wide" in msg
    assert "2.3 px cells = 0.12 m" in msg and "more than the limit 1024: crop the map" in msg


def test_a_passage_within_reach_says_which_size_keeps_it_open():
    occ = np.zeros((1200, 1200), dtype=bool)
    occ[600:604, :] = True
    occ[600:604, 700:703] = False  # a 3 px gap
    route = full_route(occ, (100, 100), (1100, 100))
    with pytest.raises(NoPathError, match=r"about 3 px wide .* --max-size 800 --size 800 keeps it open"):
        choose_size(occ, (100, 100), (1100, 100), route.cost, 128)


def test_size_to_open():
    assert size_to_open(1200, 3) == 800  # 1.5 px cells: a whole cell inside a 3 px gap wherever borders fall
    assert size_to_open(100, 0.5) == 200  # never cells narrower than half a pixel's worth of width
