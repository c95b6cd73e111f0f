"""The safe planning grid: square cells, conservative blocking, inflation by the robot's radius."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ndrql.errors import NdrqlError, PointError
from ndrql.maps.safe import (
    cell_centre,
    cell_size_px,
    conservative_grid,
    grid_shape,
    inflate,
    point_to_square_cell,
    radius_to_px,
)


def brute_conservative(obstacles: np.ndarray, size: int) -> np.ndarray:
    """Cell blocked iff a pixel square overlaps the cell square with positive area (float geometry)."""
    h, w = obstacles.shape
    s = max(h, w) / size
    rows, cols = grid_shape((h, w), size)
    out = np.zeros((rows, cols), dtype=bool)
    for i in range(rows):
        for j in range(cols):
            r0, r1 = math.floor(i * s + 1e-9), min(h, math.ceil((i + 1) * s - 1e-9))
            c0, c1 = math.floor(j * s + 1e-9), min(w, math.ceil((j + 1) * s - 1e-9))
            out[i, j] = obstacles[r0:r1, c0:c1].any()
    return out


def touched_pixels(p0: tuple[float, float], p1: tuple[float, float], shape: tuple[int, int]) -> list[tuple[int, int]]:
    """Pixels whose closed square an axis-aligned segment touches (off-map ones included)."""
    (r0, c0), (r1, c1) = sorted([p0, p1])
    rows = range(math.floor(min(r0, r1) - 0.5), math.ceil(max(r0, r1) + 0.5) + 1)
    cols = range(math.floor(min(c0, c1) - 0.5), math.ceil(max(c0, c1) + 0.5) + 1)
    return [(r, c) for r in rows for c in cols
            if r - 0.5 <= max(r0, r1) and r + 0.5 >= min(r0, r1) and c - 0.5 <= max(c0, c1) and c + 0.5 >= min(c0, c1)]


def test_square_cells_on_a_non_square_map():
    assert cell_size_px((300, 400), 50) == 8.0
    # 300 rows / 8 px = 37.5 cells: the half cell at the bottom has its centre on the map's edge -> not a cell
    assert grid_shape((300, 400), 50) == (37, 50)
    assert grid_shape((400, 300), 50) == (50, 37)
    assert grid_shape((201, 201), 50) == (50, 50)
    assert grid_shape((301, 400), 50) == (38, 50)  # 37.625 cells: the last one's centre (299.5) is inside
    blocked = conservative_grid(np.zeros((300, 400), dtype=bool), 50)
    assert blocked.shape == (37, 50) and not blocked.any()
    assert cell_centre((0, 0), (300, 400), 50) == (3.5, 3.5)
    assert cell_centre((36, 49), (300, 400), 50) == (291.5, 395.5)
    assert point_to_square_cell((299, 399), (300, 400), 50) == (36, 49)  # the uncovered strip goes to the last row
    assert point_to_square_cell((7, 8), (300, 400), 50) == (0, 1)
    with pytest.raises(PointError):
        point_to_square_cell((300, 0), (300, 400), 50)
    with pytest.raises(NdrqlError, match="too thin"):
        grid_shape((3, 400), 50)


def test_a_one_pixel_wall_survives_at_any_size():
    m = np.zeros((2000, 2000), dtype=bool)
    m[1000, :1900] = True  # 1 px wall with a 100 px opening on the right
    for size in (32, 50, 64, 128, 256):
        g = conservative_grid(m, size)
        row = int(1000 * size // 2000)
        assert g[row, : int(1800 * size // 2000)].all(), size
        assert not g[row, -1], size  # the opening stays open (it is wider than two cells)


def test_a_door_narrower_than_a_cell_closes_and_one_two_cells_wide_stays_open():
    m = np.zeros((400, 400), dtype=bool)
    m[200:204, :] = True
    narrow = m.copy()
    narrow[200:204, 100:107] = False  # 7 px door, cells of 8 px: no cell fits inside
    assert conservative_grid(narrow, 50)[25].all()
    for d0 in range(100, 120):  # a 16 px door (two cells) always contains one whole cell column
        wide = m.copy()
        wide[200:204, d0:d0 + 16] = False
        g = conservative_grid(wide, 50)
        assert (~g[25]).sum() in (1, 2), d0
    aligned = m.copy()
    aligned[200:204, 104:116] = False  # 12 px (1.5 cells) covering cell 13 (cols 104..111): open
    assert np.nonzero(~conservative_grid(aligned, 50)[25])[0].tolist() == [13]
    shifted = m.copy()
    shifted[200:204, 105:117] = False  # the same 12 px door off the cell boundary: closes
    assert conservative_grid(shifted, 50)[25].all()


@pytest.mark.parametrize("shape,size", [((37, 53), 10), ((53, 37), 13), ((20, 20), 7), ((9, 14), 20), ((64, 64), 64),
                                        ((100, 30), 33), ((5, 7), 3)])
def test_conservative_grid_matches_brute_force(shape, size):
    rng = np.random.default_rng(size)
    for density in (0.01, 0.05, 0.2):
        m = rng.random(shape) < density
        np.testing.assert_array_equal(conservative_grid(m, size), brute_conservative(m, size))


@pytest.mark.parametrize("shape,size", [((60, 90), 11), ((90, 61), 13), ((40, 40), 9), ((17, 29), 40), ((33, 100), 24)])
def test_moves_between_free_neighbour_cells_never_touch_an_obstacle(shape, size):
    rng = np.random.default_rng(sum(shape) + size)
    m = rng.random(shape) < 0.02
    g = conservative_grid(m, size)
    h, w = shape
    for i, j in zip(*np.nonzero(~g)):
        a = cell_centre((i, j), shape, size)
        assert -0.5 < a[0] < h - 0.5 and -0.5 < a[1] < w - 0.5  # every centre strictly on the map
        for di, dj in ((0, 1), (1, 0)):
            if i + di < g.shape[0] and j + dj < g.shape[1] and not g[i + di, j + dj]:
                b = cell_centre((i + di, j + dj), shape, size)
                for r, c in touched_pixels(a, b, shape):
                    assert 0 <= r < h and 0 <= c < w and not m[r, c], ((i, j), (i + di, j + dj), (r, c))


def test_inflation_closes_a_gap_narrower_than_the_robot():
    m = np.zeros((60, 200), dtype=bool)
    m[30, :100] = True
    m[30, 110:] = True  # a 10 px gap (cols 100..109)
    assert not inflate(m, 0)[30, 100:110].any()
    open4 = inflate(m, 4)  # pixels within 4 px of the wall: cols 100..103 and 106..109
    assert open4[30, 100:104].all() and open4[30, 106:110].all() and not open4[30, 104:106].any()
    assert not inflate(m, 4.9)[30, 104:106].all() and inflate(m, 5)[30, 100:110].all()  # closes at r = g / 2
    grown = inflate(m, 3)
    assert grown[27, 50] and grown[33, 50] and not grown[26, 50]  # the wall grows 3 px on both sides
    assert grown[28, 112] and not grown[27, 108]  # round corners: (27, 108) is sqrt(13) > 3 from (30, 110)
    assert not inflate(np.zeros((5, 5), bool), 3).any()
    assert np.array_equal(inflate(m, 0.9), m)


def test_radius_units():
    assert radius_to_px(0.25, 0.05) == pytest.approx(5.0)
    assert radius_to_px(3, None) == 3.0
    with pytest.raises(NdrqlError):
        radius_to_px(-1, None)
    with pytest.raises(NdrqlError):
        radius_to_px(float("nan"), 0.05)


@pytest.mark.parametrize("seed", range(8))
def test_inflation_equals_the_distance_transform(seed):
    from scipy import ndimage

    rng = np.random.default_rng(seed)
    h, w = rng.integers(3, 90, 2)
    m = rng.random((h, w)) < rng.uniform(0.001, 0.2)
    for r in (1.0, 1.5, 2.0, 2.9, 3.0, 4.2, 5.0, 7.07, 12.5, 60.0):
        np.testing.assert_array_equal(inflate(m, r), m | (ndimage.distance_transform_edt(~m) <= r), err_msg=str(r))
