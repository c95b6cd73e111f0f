"""Planning grid (SPEC section 1): exact area averaging, >= 0.5 rule, cell mapping, snapping, connectivity."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ndrql.errors import NoPathError, PointError
from ndrql.maps import (
    GridMap,
    PlanningGrid,
    SnapWarning,
    area_downscale,
    bfs_distances,
    nearest_free_bfs,
    planning_grid,
    point_to_cell,
)


def test_gridmap_is_frozen_and_read_only():
    arr = np.zeros((3, 4), dtype=np.uint8)
    m = GridMap(arr, source="x")
    arr[0, 0] = 1  # the map keeps its own copy
    assert m.obstacles.dtype == bool and not m.obstacles.any()
    assert m.shape == (3, 4) and m.height == 3 and m.width == 4
    with pytest.raises(ValueError):
        m.obstacles[0, 0] = True
    with pytest.raises(AttributeError):
        m.source = "y"  # type: ignore[misc]
    with pytest.raises(ValueError):
        GridMap(np.zeros((0, 3)))


def test_area_downscale_integer_ratio_by_hand():
    a = np.array([[1, 1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 1], [0, 0, 1, 1]], dtype=float)
    np.testing.assert_allclose(area_downscale(a, (2, 2)), [[0.75, 0.0], [0.0, 1.0]])


def test_area_downscale_fractional_ratio_by_hand():
    # 3x3 -> 2x2: cell (0, 0) covers rows [0, 1.5) and cols [0, 1.5), area 2.25 px.
    a = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 0]], dtype=float)
    out = area_downscale(a, (2, 2))
    # cell (0,0): pixel (0,0) full (1.0) + pixel (1,1) quarter (0.25) -> 1.25 / 2.25
    assert out[0, 0] == pytest.approx(1.25 / 2.25)
    # cell (1,1): only a quarter of pixel (1,1) -> 0.25 / 2.25
    assert out[1, 1] == pytest.approx(0.25 / 2.25)
    # cell (0,1): half of pixel (1,1) (rows [1,1.5) of it) -> 0.5 * 0.5 = 0.25 px
    assert out[0, 1] == pytest.approx(0.25 / 2.25)


def test_area_downscale_non_square_and_upscale():
    a = np.zeros((2, 6))
    a[:, :3] = 1
    np.testing.assert_allclose(area_downscale(a, (1, 2)), [[1.0, 0.0]])
    np.testing.assert_allclose(area_downscale(np.array([[1.0, 0.0]]), (2, 4)), [[1, 1, 0, 0], [1, 1, 0, 0]])


@settings(max_examples=40, deadline=None)
@given(
    arrays(np.float64, st.tuples(st.integers(1, 30), st.integers(1, 30)), elements=st.floats(0, 1)),
    st.integers(1, 12),
    st.integers(1, 12),
)
def test_area_downscale_preserves_the_mean(a, h, w):
    assert area_downscale(a, (h, w)).mean() == pytest.approx(a.mean(), abs=1e-9)


def test_half_obstacle_cell_is_blocked_exactly():
    assert planning_grid(np.array([[1, 1], [0, 0]]), (1, 1))[0, 0]
    assert not planning_grid(np.array([[1, 0], [0, 0]]), (1, 1))[0, 0]
    # 201 -> 50: cell 0 spans 4.02 px; 2.01 px of obstacle rows is exactly half
    a = np.zeros((201, 201), dtype=bool)
    a[:2, :] = True
    assert not planning_grid(a)[0].any()  # cell row 0 spans 4.02 px: 2 / 4.02 < 0.5
    a[2, :] = True
    assert planning_grid(a)[0].all()  # 3 / 4.02 >= 0.5
    assert not planning_grid(a)[1].any()


def test_planning_grid_any_size_and_aspect():
    a = np.zeros((100, 300), dtype=bool)
    a[:, 150:] = True
    g = planning_grid(a)
    assert g.shape == (50, 50)
    assert not g[:, :25].any() and g[:, 25:].all()
    assert planning_grid(np.ones((7, 3), dtype=bool), (5, 4)).all()


def test_point_to_cell_contains_pixel_centre():
    assert point_to_cell((0, 0), (201, 201), (50, 50)) == (0, 0)
    assert point_to_cell((200, 200), (201, 201), (50, 50)) == (49, 49)
    assert point_to_cell((100, 4), (201, 201), (50, 50)) == (25, 1)  # centre 100.5 / 4.02 = 25.0
    assert point_to_cell((3, 9), (4, 10), (2, 5)) == (1, 4)
    with pytest.raises(PointError):
        point_to_cell((201, 0), (201, 201), (50, 50))


def test_snap_moves_point_to_nearest_free_cell_with_warning():
    a = np.zeros((10, 10), dtype=bool)
    a[0:4, 0:4] = True  # cells (0,0),(0,1),(1,0),(1,1) of a 5x5 grid blocked
    with pytest.warns(SnapWarning, match="start"):
        pg = PlanningGrid.from_map(GridMap(a), (1, 1), (9, 9), size=5)
    assert pg.start in {(0, 2), (2, 0)}  # BFS distance 2 from (0, 0)
    assert pg.snapped == (True, False)
    assert pg.goal == (4, 4)
    assert nearest_free_bfs(pg.blocked, (1, 1)) in {(1, 2), (2, 1)}


def test_no_warning_when_cell_is_free():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pg = PlanningGrid.from_map(np.zeros((201, 201), bool), (0, 0), (200, 200))
    assert (pg.start, pg.goal, pg.snapped) == ((0, 0), (49, 49), (False, False))
    assert pg.to_strings() == ["." * 50] * 50


def test_disconnected_start_goal_raises_no_path_error():
    a = np.zeros((201, 201), dtype=bool)
    a[:, 95:105] = True  # a full-height wall
    with pytest.raises(NoPathError, match="not 4-connected"):
        PlanningGrid.from_map(a, (10, 10), (10, 190))
    pg = PlanningGrid.from_map(a, (10, 10), (10, 190), check=False)
    assert bfs_distances(pg.blocked, pg.start)[pg.goal] == -1


def test_narrow_gap_closes_on_the_planning_grid():
    a = np.zeros((201, 201), dtype=bool)
    a[:, 95:105] = True
    a[100:102, 95:105] = False  # a 2 px gap: open on the map, blocked at >= 0.5
    with pytest.raises(NoPathError):
        PlanningGrid.from_map(a, (10, 10), (10, 190))


def test_point_off_map_raises_point_error():
    with pytest.raises(PointError, match="off the map"):
        PlanningGrid.from_map(np.zeros((20, 30), bool), (0, 30), (5, 5))
    with pytest.raises(PointError, match="goal"):
        PlanningGrid.from_map(np.zeros((20, 30), bool), (0, 0), (-1, 5))


def test_bfs_distances_by_hand():
    blocked = np.array([[0, 1, 0], [0, 1, 0], [0, 0, 0]], dtype=bool)
    np.testing.assert_array_equal(bfs_distances(blocked, (0, 0)), [[0, -1, 6], [1, -1, 5], [2, 3, 4]])
