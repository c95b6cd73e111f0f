"""The C map kernels (``ndrql.maps._kernels``) answer as numba's do, bit for bit, on many random problems.

numba's kernels are the reference: :func:`ndrql.maps.astar_kernel.astar8_kernel` (path, cost, expanded
nodes, with and without corner cutting, reachable or not) and the segment kernels of
:mod:`ndrql.maps.lines_kernel` (the supercover, the first blocked pixel, the shortcut), on random maps
and random integer, half-integer and arbitrary float end points, on and off the map.
"""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.maps import lines, lines_kernel, native
from ndrql.maps.astar import kernel_map
from ndrql.maps.astar_kernel import astar8_kernel

pytestmark = pytest.mark.skipif(native.extension() is None, reason="the C extension ndrql.maps._kernels is not built "
                                "(pip install -e . with a C compiler, or python setup.py build_ext --inplace)")


@pytest.fixture
def ck(monkeypatch):
    monkeypatch.setenv(native.KERNELS_ENV, "c")
    return native.c_kernels()


def _astar_c(ck, blocked: np.ndarray, s: int, g: int, cut: bool) -> tuple[np.ndarray, float, int]:
    h, w = blocked.shape
    raw, cost, expanded = ck.astar8(blocked, h, w, s, g, cut)
    return np.frombuffer(raw, dtype=np.int64), cost, expanded


def test_astar_equals_numba_on_random_maps(ck):
    """1,200 searches: maps 1-60 cells a side, obstacle density 0-0.5, both corner rules."""
    gen = np.random.default_rng(11)
    reached = missed = 0
    for case in range(1200):
        h, w = (int(x) for x in gen.integers(1, 61, size=2))
        blocked = kernel_map(gen.random((h, w)) < gen.uniform(0.0, 0.5))
        s, g = (int(x) for x in gen.integers(0, h * w, size=2))
        cut = bool(gen.integers(0, 2))
        ref = astar8_kernel(blocked, s, g, cut)
        got = _astar_c(ck, blocked, s, g, cut)
        assert ref[0].dtype == got[0].dtype and np.array_equal(ref[0], got[0]), case
        assert np.float64(ref[1]).tobytes() == np.float64(got[1]).tobytes() and ref[2] == got[2], case
        reached += len(ref[0]) > 0
        missed += len(ref[0]) == 0
    assert reached > 300 and missed > 100


def test_astar_equals_numba_on_a_large_open_map_with_many_ties(ck):
    """The heap grows far past its first block, and equal priorities are ordered by push count."""
    blocked = np.zeros((300, 300), dtype=bool)
    blocked[50:250, 150] = True
    blocked = kernel_map(blocked)
    for s, g in ((0, 300 * 300 - 1), (150 * 300 + 10, 150 * 300 + 290), (299, 299 * 300)):
        ref = astar8_kernel(blocked, s, g, False)
        got = _astar_c(ck, blocked, s, g, False)
        assert np.array_equal(ref[0], got[0]) and ref[1] == got[1] and ref[2] == got[2]


def _points(gen: np.random.Generator, h: int, w: int, n: int) -> np.ndarray:
    """``n`` points in and around an ``h`` x ``w`` map: integers, half-integers or arbitrary floats."""
    pts = gen.uniform(-3, [h + 3, w + 3], size=(n, 2))
    kind = gen.integers(0, 3)
    if kind == 0:
        return np.round(pts)
    if kind == 1:
        return np.round(pts * 2) / 2
    return pts


def test_segment_kernels_equal_numba_on_random_segments(ck):
    """4,000 segments: the supercover and the first blocked pixel, each pair against numba's."""
    gen = np.random.default_rng(12)
    blocked_seen = 0
    for case in range(400):
        h, w = (int(x) for x in gen.integers(1, 40, size=2))
        obstacles = kernel_map(gen.random((h, w)) < gen.uniform(0.0, 0.3))
        pts = _points(gen, h, w, 20)
        for k in range(10):
            (r0, c0), (r1, c1) = (float(v) for v in pts[2 * k]), (float(v) for v in pts[2 * k + 1])
            if k == 9:
                r1, c1 = r0, c0  # a degenerate segment
            ref = lines_kernel._supercover(r0, c0, r1, c1)
            got = np.frombuffer(ck.supercover(r0, c0, r1, c1), dtype=np.int64).reshape(-1, 2)
            assert np.array_equal(ref, got), (case, k)
            ref_b = lines_kernel._first_blocked(obstacles, r0, c0, r1, c1)
            got_b = ck.first_blocked(obstacles, h, w, r0, c0, r1, c1)
            assert (bool(ref_b[0]), int(ref_b[1]), int(ref_b[2])) == got_b, (case, k)
            blocked_seen += got_b[0]
    assert 500 < blocked_seen < 3900


def test_shortcut_equals_numba_on_random_polylines(ck):
    """600 polylines of 1-40 points on random maps (free and colliding ones)."""
    gen = np.random.default_rng(13)
    for case in range(600):
        h, w = (int(x) for x in gen.integers(2, 50, size=2))
        obstacles = kernel_map(gen.random((h, w)) < gen.uniform(0.0, 0.2))
        pts = np.ascontiguousarray(_points(gen, h, w, int(gen.integers(1, 41))), dtype=np.float64)
        ref = lines_kernel._shortcut(obstacles, pts)
        got = np.frombuffer(ck.shortcut(obstacles, h, w, pts), dtype=np.int64)
        assert np.array_equal(ref, got), case


def test_the_public_functions_answer_alike_through_either_kernel(monkeypatch):
    """What callers use (``lines.*``, ``shortest_path8``) gives the same results under either choice."""
    from ndrql.maps.astar import shortest_path8

    gen = np.random.default_rng(14)
    obstacles = gen.random((40, 40)) < 0.15
    obstacles[0, 0] = obstacles[39, 39] = False
    pts = gen.uniform(0, 39, size=(30, 2))
    out = {}
    for choice in ("numba", "c"):
        monkeypatch.setenv(native.KERNELS_ENV, choice)
        try:
            path = shortest_path8(obstacles, (0, 0), (39, 39))
        except Exception as exc:  # noqa: BLE001 (no path is an answer too)
            path = type(exc).__name__
        out[choice] = (path, lines.polyline_collisions(obstacles, pts), lines.shortcut(obstacles, pts).tolist(),
                       lines.segment_pixels(pts[0], pts[1]).tolist(), lines.segment_free(obstacles, pts[2], pts[3]))
    assert out["numba"] == out["c"]


def test_the_tolerance_is_one_value():
    assert lines.EPS == lines_kernel.EPS == 1e-9
