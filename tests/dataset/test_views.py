"""Views of a large planning grid for a grid-mode model: native is today's input exactly; cap and coarse
draw fewer pixels and bring the outputs back to the planning grid."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.dataset.render import cell_means, grid_input, manhattan_pixels, merge_cells, merge_walls, render_grid
from ndrql.dataset.views import GridView, view_cells, view_distance_cells, view_input, view_note
from ndrql.errors import NdrqlError


def grid(h: int = 10, w: int = 8) -> np.ndarray:
    b = np.zeros((h, w), bool)
    b[4, 1:7] = True
    return b


def test_parse_and_errors():
    assert GridView.parse("native") == GridView()
    assert GridView.parse("cap:512") == GridView("cap", 512)
    assert str(GridView.parse(" coarse:128 ")) == "coarse:128"
    assert GridView.parse("walls:128") == GridView("walls", 128) and GridView("walls", 128).factor(256) == 2
    for bad in ("tiles:4", "cap", "cap:x", "coarse:1", "native:3", "walls"):
        with pytest.raises(NdrqlError) as e:
            GridView.parse(bad)
        assert "\n" not in str(e.value)


def test_native_is_todays_input_and_cell_means():
    b = grid()
    vi = view_input(b, (0, 0), (9, 7), GridView())
    img, s, g = grid_input(b, (0, 0), (9, 7), 10)
    assert np.array_equal(vi.image, img) and (vi.start, vi.goal) == (s, g) and (vi.px, vi.factor) == (4, 1)
    prob = np.random.default_rng(0).random(img.shape)
    assert np.allclose(view_cells(prob, vi), cell_means(prob, b.shape))


def test_px_per_cell_of_cap():
    v = GridView("cap", 512)
    assert [v.px_per_cell(n) for n in (64, 128, 170, 256, 512, 1024)] == [4, 4, 3, 2, 1, 1]
    assert GridView("coarse", 128).factor(256) == 2 and GridView("coarse", 128).factor(128) == 1
    assert GridView("coarse", 100).factor(256) == 3


def test_cap_draws_two_px_per_cell_and_averages_back():
    b = grid()
    vi = view_input(b, (0, 0), (9, 7), GridView("cap", 20))  # 20 // 10 = 2 px per cell
    assert vi.image.shape == (20, 20) and vi.px == 2
    assert vi.image[8:10, 2:14].all() and not vi.image[0:8, 0:16].any()  # the wall at row 4, columns 1-6
    assert vi.image[:, 16:].all()  # padding to a square
    assert (vi.start, vi.goal) == ((1, 1), (19, 15))
    prob = np.zeros((20, 20))
    prob[2:4, 4:6] = 1.0  # exactly cell (1, 2)
    prob[0, 0] = 0.8  # a quarter of cell (0, 0)
    cells = view_cells(prob, vi)
    assert cells.shape == b.shape and cells[1, 2] == 1.0 and cells[0, 0] == pytest.approx(0.2)
    assert cells.sum() == pytest.approx(1.2)


def test_merge_cells_keeps_every_route_open():
    b = np.ones((5, 5), bool)
    b[2, :] = False  # a one-cell corridor across
    m = merge_cells(b, 2)
    assert m.shape == (3, 3)
    assert not m[1].any() and m[0].all() and m[2].all()  # the corridor's merged cells are free, padding blocked
    assert np.array_equal(merge_cells(b, 1), b)


def test_coarse_upsamples_each_cell_from_its_merged_cell():
    b = np.zeros((6, 6), bool)
    vi = view_input(b, (0, 0), (5, 5), GridView("coarse", 3))
    assert vi.factor == 2 and vi.px == 4 and vi.image.shape == (12, 12)
    assert (vi.start, vi.goal) == ((2, 2), (10, 10))
    prob = np.zeros((12, 12))
    prob[4:8, 8:12] = 0.5  # seen cell (1, 2)
    cells = view_cells(prob, vi)
    assert cells.shape == (6, 6) and (cells[2:4, 4:6] == 0.5).all() and cells.sum() == pytest.approx(2.0)


def test_distance_in_planning_cells():
    """A zero detour is the Manhattan distance the model believes in, scaled to planning cells."""
    b = np.zeros((8, 8), bool)
    for view, expect_scale in ((GridView(), 1), (GridView("cap", 16), 2), (GridView("coarse", 4), 2)):
        vi = view_input(b, (0, 0), (7, 7), view)
        d = view_distance_cells(np.zeros(vi.image.shape), vi)
        assert d.shape == (8, 8)
        seen = manhattan_pixels(vi.goal, vi.image.shape[0])
        assert d[0, 0] == pytest.approx(seen[0, 0] * expect_scale)
    vi = view_input(b, (0, 0), (7, 7), GridView())
    assert np.array_equal(view_distance_cells(np.zeros((32, 32)), vi),
                          np.abs(np.arange(8) - 7)[:, None] + np.abs(np.arange(8) - 7)[None, :])


def test_render_grid_native_view_is_unchanged():
    from ndrql.dataset.render import render_grid

    obstacles = np.zeros((160, 160), bool)
    obstacles[60:70, 20:140] = True
    a = render_grid(obstacles, (5, 5), (150, 150), 40)
    b = render_grid(obstacles, (5, 5), (150, 150), 40, GridView())
    for f in ("obstacles", "guideline", "region", "distance"):
        assert np.array_equal(getattr(a, f), getattr(b, f))
    assert (a.start, a.goal) == (b.start, b.goal)


@pytest.mark.parametrize("view, side, px", [(GridView("cap", 80), 80, 2), (GridView("coarse", 20), 80, 4)])
def test_render_grid_under_a_view_draws_what_the_view_shows(view, side, px):
    """Input, start and goal as :func:`view_input` draws them; labels drawn at the view's px per seen cell;
    the distance label in the 4 px cells the model perceives."""
    from ndrql.dataset.render import render_grid
    from ndrql.maps.safe import conservative_grid

    obstacles = np.zeros((160, 160), bool)
    obstacles[60:70, 0:140] = True  # a wall with a way round on the right
    r = render_grid(obstacles, (5, 5), (150, 5), 40, view)
    blocked = conservative_grid(obstacles, 40)
    vi = view_input(blocked, (1, 1), (37, 1), view)
    assert r.obstacles.shape == (side, side) and np.array_equal(r.obstacles, vi.image)
    assert (r.start, r.goal) == (vi.start, vi.goal)
    assert r.guideline[r.start] and r.guideline[r.goal] and not (r.guideline & r.obstacles).all()
    assert r.region.sum() > r.guideline.sum()
    # the goal's own cell is 0 moves away, the start's is the seen grid's BFS distance times px / 4
    assert r.distance[r.goal] == 0
    seen = merge_cells(blocked, vi.factor)
    from ndrql.maps.grid import bfs_distances
    moves = bfs_distances(seen, (vi.goal[0] // px, vi.goal[1] // px))[vi.start[0] // px, vi.start[1] // px]
    assert r.distance[r.start] == pytest.approx(moves * px / 4)


def test_view_side():
    assert GridView().side(256) == 1024
    assert GridView("cap", 512).side(256) == 512 and GridView("cap", 512).side(100) == 400
    assert GridView("coarse", 128).side(256) == 512 and GridView("coarse", 128).side(200) == 400


def test_merge_walls_keeps_thin_walls_and_falls_back_when_they_close_the_way():
    """A wall one cell thick between two rooms, with a door two cells wide: ``coarse`` opens the wall
    everywhere, ``walls`` keeps it and its door (the route stays the real one); a door one cell wide that
    the walls merge closes sends ``walls`` back to ``coarse``."""
    b = np.zeros((8, 8), bool)
    b[:, 3] = True  # a wall one cell thick, in column 3
    b[4:6, 3] = False  # a door of two cells, rows 4-5
    s, g = (0, 0), (0, 7)
    assert not merge_cells(b, 2).any()  # coarse: the wall is gone, the straight line is free
    w = merge_walls(b, 2, s, g)
    assert w[:, 1].tolist() == [True, True, False, True] and not w[:, 0].any()  # wall kept, door at merged row 2
    one = b.copy()
    one[5, 3] = True  # the door narrows to one cell (row 4): merged, rows 4-5 of column 3 are blocked
    assert np.array_equal(merge_walls(one, 2, s, g), merge_cells(one, 2))
    # start and goal stay free even when their merged cell holds a wall
    b2 = np.zeros((4, 4), bool)
    b2[0, 1] = True
    assert not merge_walls(b2, 2, (0, 0), (3, 3))[0, 0]


def test_walls_view_draws_and_renders_the_walled_grid():
    b = np.zeros((40, 40), bool)
    b[:, 19] = True
    b[30:34, 19] = False  # a door of four cells
    v = GridView("walls", 20)
    vi = view_input(b, (0, 0), (0, 39), v)
    assert vi.factor == 2 and vi.image.shape == (80, 80)
    seen = vi.image[::4, ::4]
    assert seen[:15, 9].all() and not seen[15:17, 9].any()  # the wall column, open at the door
    assert not view_input(b, (0, 0), (0, 39), GridView("coarse", 20)).image.any()  # coarse: no wall at all
    obstacles = np.kron(b, np.ones((4, 4), bool))  # the grid as a 160 px map
    r = render_grid(obstacles, (2, 2), (2, 157), 40, view=v)
    assert r is not None and r.obstacles.shape == (80, 80) and r.obstacles[:60, 36:40].any()
    assert view_note("walls:20", 2) == ", view walls:20, 2x2 cells seen as one" and view_note("walls:20", 1) == ""
