"""The compiled drawing of the exact source (``ndrql.maps.route_cells``) and the far-filled BFS field give numpy's
bits, and each runs the C kernel when the extension is built and numpy (numba for the BFS) when it is not."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.errors import NoPathError
from ndrql.maps import fields, native, route_cells
from ndrql.maps.astar import shortest_path8, shortest_path8_cells
from ndrql.maps.grid import bfs_distances

needs_c = pytest.mark.skipif(getattr(native.extension(), "route_cells", None) is None,
                             reason="the C extension ndrql.maps._kernels (with route_cells) is not built")


def _polyline(gen: np.random.Generator, rows: int, cols: int, px: int) -> np.ndarray:
    """0-8 waypoints, on and off the image, at cell centres or anywhere, a repeated point now and then."""
    k = int(gen.integers(0, 9))
    wp = gen.uniform(-3.0, [rows * px + 3.0, cols * px + 3.0], size=(k, 2))
    if gen.random() < 0.5:
        wp = np.round(wp) + (px - 1) / 2
    if k > 1 and gen.random() < 0.2:
        wp[-1] = wp[0]
    return wp


@needs_c
def test_route_cells_equals_numpy_bit_for_bit(monkeypatch):
    """600 polylines on grids of 1-60 cells a side, 1-5 px per cell, guides 1-3 px, regions 1-39 px."""
    monkeypatch.setenv(native.KERNELS_ENV, "c")
    gen = np.random.default_rng(53)
    drawn = 0
    for case in range(600):
        rows, cols = (int(x) for x in gen.integers(1, 61, size=2))
        px, guide, region = int(gen.integers(1, 6)), int(gen.integers(1, 4)), int(gen.integers(1, 40))
        wp = _polyline(gen, rows, cols, px)
        got = route_cells.route_cells(wp, (rows, cols), px, guide, region)
        ref = route_cells.route_cells_numpy(wp, (rows, cols), px, guide, region)
        for g, r in zip(got, ref):
            assert g.shape == r.shape == (rows, cols) and g.dtype == r.dtype == np.float64, case
            assert g.tobytes() == r.tobytes(), case
        drawn += bool(ref[1].any())
    assert drawn > 400


def _filled_reference(blocked: np.ndarray, goal: tuple[int, int]) -> np.ndarray:
    """The exact source's goal distance as numpy computed it before its kernel."""
    d = bfs_distances(blocked, goal).astype(np.float64)
    if (d < 0).any():
        rows, cols = np.indices(d.shape)
        far = (d.max() if (d >= 0).any() else 0.0) + np.abs(rows - goal[0]) + np.abs(cols - goal[1])
        d = np.where(d < 0, far, d)
    return d


@pytest.mark.parametrize("kernels", ["c", "numba"])
def test_bfs4_filled_equals_the_numpy_field(monkeypatch, kernels):
    if kernels == "c" and getattr(native.extension(), "far_field", None) is None:
        pytest.skip("the C extension (with far_field) is not built")
    monkeypatch.setenv(native.KERNELS_ENV, kernels)
    gen = np.random.default_rng(7)
    for case in range(150):
        h, w = (int(x) for x in gen.integers(1, 40, size=2))
        blocked = gen.random((h, w)) < gen.uniform(0.0, 0.6)
        goal = (int(gen.integers(0, h)), int(gen.integers(0, w)))
        got = fields.bfs4_filled(blocked, goal)
        assert got.dtype == np.float64 and got.tobytes() == _filled_reference(blocked, goal).tobytes(), case


def test_bfs4_filled_known_values():
    """A wall cuts the right column off: the wall and the cells behind it take the largest distance (1) plus their
    Manhattan distance to the goal."""
    blocked = np.array([[0, 1, 0], [0, 1, 0]], bool)
    got = fields.bfs4_filled(blocked, (0, 0))
    assert got.tolist() == [[0.0, 2.0, 3.0], [1.0, 3.0, 4.0]]


class _Spy:
    """Stands in for the extension: records which kernels were asked."""

    def __init__(self, real):
        self.real, self.calls = real, []

    def __getattr__(self, name):
        self.calls.append(name)
        return getattr(self.real, name)


@needs_c
def test_dispatch_runs_the_c_kernels_when_built(monkeypatch):
    spy = _Spy(native.extension())
    monkeypatch.setattr(route_cells, "c_kernels", lambda: spy)
    monkeypatch.setattr(fields, "c_kernels", lambda: spy)
    monkeypatch.setattr(route_cells, "route_cells_numpy", lambda *a: pytest.fail("numpy ran while C is built"))
    route_cells.route_cells(np.array([[1.5, 1.5], [30.5, 20.5]]), (10, 10), 4, 2, 30)
    fields.bfs4_filled(np.zeros((5, 5), bool), (2, 2))
    assert spy.calls == ["route_cells", "far_field"]


def test_dispatch_falls_back_to_numpy_without_the_extension(monkeypatch):
    monkeypatch.setenv(native.KERNELS_ENV, "numba")
    ran = []
    real = route_cells.route_cells_numpy
    monkeypatch.setattr(route_cells, "route_cells_numpy", lambda *a: ran.append(1) or real(*a))
    region, guide = route_cells.route_cells(np.array([[1.5, 1.5], [30.5, 20.5]]), (10, 10), 4, 2, 30)
    assert ran == [1] and guide.sum() > 0 and region[0, 0] == 1.0
    blocked = np.zeros((4, 4), bool)
    blocked[:, 2] = True
    assert fields.bfs4_filled(blocked, (0, 0))[0, 3] == 4 + 0 + 3  # the farthest free cell (3, 1) is 4 moves away


def test_shortest_path8_cells_is_shortest_path8s_path():
    """The exact source's path as an array: the cells of :func:`shortest_path8`'s path, in order."""
    gen = np.random.default_rng(8)
    for case in range(40):
        blocked = gen.random((30, 40)) < 0.2
        blocked[0, 0] = blocked[29, 39] = False
        try:
            ref = shortest_path8(blocked, (0, 0), (29, 39)).path
        except NoPathError:
            with pytest.raises(NoPathError):
                shortest_path8_cells(blocked, (0, 0), (29, 39))
            continue
        got = shortest_path8_cells(blocked, (0, 0), (29, 39))
        assert got.dtype == np.int64 and got.shape == (len(ref), 2) and got.tolist() == [list(p) for p in ref], case
