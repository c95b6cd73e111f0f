"""The grid fields (:mod:`ndrql.maps.fields`): move counts and the widest path, against pure-Python references,
and the C kernels against numba's twins (:mod:`ndrql.maps.fields_kernel`), on many random grids.

The BFS reference is the deque search ``bfs_distances`` ran before it was compiled; the widest-path reference
asks, for every distinct value ``v`` from the highest down, whether the free cells with a value ``>= v`` join the
two ends (the first that does is the answer).
"""

from __future__ import annotations

from collections import deque

import numpy as np
import pytest

from ndrql.maps import native
from ndrql.maps.fields import bfs4, bottleneck4
from ndrql.maps.fields_kernel import bfs4_kernel, bottleneck4_kernel
from ndrql.maps.grid import MOVES4, bfs_distances

needs_c = pytest.mark.skipif(native.extension() is None, reason="the C extension ndrql.maps._kernels is not built")


def reference_bfs(blocked: np.ndarray, source: tuple[int, int]) -> np.ndarray:
    """``bfs_distances`` as it was in pure Python (a deque BFS)."""
    blocked = np.asarray(blocked, dtype=bool)
    h, w = blocked.shape
    dist = np.full((h, w), -1, dtype=np.int64)
    sr, sc = source
    if blocked[sr, sc]:
        return dist
    dist[sr, sc] = 0
    queue = deque([(sr, sc)])
    while queue:
        r, c = queue.popleft()
        for dr, dc in MOVES4:
            nr, nc = r + dr, c + dc
            if 0 <= nr < h and 0 <= nc < w and dist[nr, nc] < 0 and not blocked[nr, nc]:
                dist[nr, nc] = dist[r, c] + 1
                queue.append((nr, nc))
    return dist


def reference_bottleneck(values: np.ndarray, blocked: np.ndarray, start, goal) -> float:
    """The widest path by brute force: the highest value ``v`` whose free cells ``>= v`` join start and goal."""
    free = ~blocked & ~np.isnan(values)
    if not (free[start] and free[goal]):
        return -np.inf
    for v in sorted(set(values[free].tolist()), reverse=True):
        if reference_bfs(~(free & (values >= v)), start)[goal] >= 0:
            return float(v)
    return -np.inf


def _grid(gen: np.random.Generator, h: int, w: int) -> np.ndarray:
    blocked = gen.random((h, w)) < gen.uniform(0.0, 0.55)
    if gen.random() < 0.3:  # walls with gaps: long detours
        for r in range(1, h - 1, 3):
            blocked[r, :] = True
            blocked[r, int(gen.integers(0, w))] = False
    return blocked


def _values(gen: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    kind = int(gen.integers(0, 4))
    if kind == 0:
        return gen.random(shape)
    if kind == 1:  # many ties
        return gen.integers(0, 4, size=shape) / 4.0
    if kind == 2:  # infinities and NaN among ordinary values
        v = gen.normal(size=shape)
        v[gen.random(shape) < 0.05] = np.inf
        v[gen.random(shape) < 0.05] = -np.inf
        v[gen.random(shape) < 0.05] = np.nan
        return v
    return np.full(shape, float(gen.integers(0, 2)))


@pytest.fixture(params=["c", "numba"])
def kernels(request, monkeypatch):
    if request.param == "c" and native.extension() is None:
        pytest.skip("the C extension is not built")
    monkeypatch.setenv(native.KERNELS_ENV, request.param)
    return request.param


def test_bfs4_equals_the_python_bfs_on_random_grids(kernels):
    """800 grids of 1-40 cells a side, sparse to dense, with walls; blocked and free sources."""
    gen = np.random.default_rng(31)
    unreachable = blocked_source = 0
    for case in range(800):
        h, w = (int(x) for x in gen.integers(1, 41, size=2))
        blocked = _grid(gen, h, w)
        src = (int(gen.integers(0, h)), int(gen.integers(0, w)))
        ref = reference_bfs(blocked, src)
        got = bfs4(blocked, src)
        assert got.dtype == np.int64 and got.shape == (h, w) and np.array_equal(ref, got), case
        assert np.array_equal(bfs_distances(blocked, src), ref), case
        blocked_source += bool(blocked[src])
        unreachable += bool(((ref < 0) & ~blocked).any())
    assert blocked_source > 50 and unreachable > 100


def test_bfs4_results_are_writable_and_independent(kernels):
    blocked = np.zeros((5, 6), dtype=bool)
    a = bfs4(blocked, (0, 0))
    a[0, 0] = 99  # callers may change their copy
    assert bfs4(blocked, (0, 0))[0, 0] == 0 and a[4, 5] == 9


def test_bottleneck4_equals_brute_force_on_random_grids(kernels):
    """1,500 problems on 1-14 cells a side: ties, infinities, NaN, blocked ends, start == goal."""
    gen = np.random.default_rng(32)
    seen = {"none": 0, "found": 0}
    for case in range(1500):
        h, w = (int(x) for x in gen.integers(1, 15, size=2))
        blocked = _grid(gen, h, w)
        values = _values(gen, (h, w))
        s = (int(gen.integers(0, h)), int(gen.integers(0, w)))
        g = s if gen.random() < 0.05 else (int(gen.integers(0, h)), int(gen.integers(0, w)))
        ref = reference_bottleneck(values, blocked, s, g)
        got = bottleneck4(values, blocked, s, g)
        assert got == ref, (case, got, ref)
        seen["none" if ref == -np.inf else "found"] += 1
    assert seen["none"] > 200 and seen["found"] > 500


def test_bottleneck4_is_the_threshold_that_joins_start_and_goal(kernels):
    """``t < B`` exactly when the free cells above ``t`` join the ends: at ``B`` itself they do not."""
    gen = np.random.default_rng(33)
    checked = 0
    for _ in range(200):
        blocked = _grid(gen, 20, 20)
        values = np.round(gen.random((20, 20)), 2)
        s, g = (0, 0), (19, 19)
        b = bottleneck4(values, blocked, s, g)
        if b == -np.inf:
            continue
        joins = lambda t: reference_bfs(blocked | ~(values > t), s)[g] >= 0  # noqa: E731
        assert not joins(b) and joins(np.nextafter(b, -np.inf))
        checked += 1
    assert checked > 30


@needs_c
def test_c_and_numba_agree_on_large_grids(monkeypatch):
    """Grids up to 300 cells a side: the heap grows far past its first block; both BFS fields equal too."""
    gen = np.random.default_rng(34)
    for case in range(12):
        n = int(gen.integers(100, 301))
        blocked = _grid(gen, n, n)
        values = _values(gen, (n, n))
        s, g = (int(gen.integers(0, n)), int(gen.integers(0, n))), (int(gen.integers(0, n)), int(gen.integers(0, n)))
        blocked[s] = blocked[g] = False
        flags = np.ascontiguousarray(blocked)
        ref_b = bottleneck4_kernel(np.ascontiguousarray(values), flags, s[0] * n + s[1], g[0] * n + g[1])
        ref_d = bfs4_kernel(flags, s[0] * n + s[1]).reshape(n, n)
        monkeypatch.setenv(native.KERNELS_ENV, "c")
        got_b, got_d = bottleneck4(values, blocked, s, g), bfs4(blocked, s)
        assert np.float64(ref_b).tobytes() == np.float64(got_b).tobytes(), case
        assert np.array_equal(ref_d, got_d), case
        monkeypatch.setenv(native.KERNELS_ENV, "numba")
        assert bottleneck4(values, blocked, s, g) == got_b and np.array_equal(bfs4(blocked, s), got_d)


def test_off_grid_cells_and_mismatched_shapes_are_refused(kernels):
    blocked = np.zeros((4, 5), dtype=bool)
    for bad in ((-1, 0), (4, 0), (0, 5), (0, -1)):
        with pytest.raises(IndexError, match="off the 4x5 grid"):
            bfs4(blocked, bad)
        with pytest.raises(IndexError, match="off the 4x5 grid"):
            bottleneck4(np.ones((4, 5)), blocked, bad, (0, 0))
        with pytest.raises(IndexError, match="off the 4x5 grid"):
            bottleneck4(np.ones((4, 5)), blocked, (0, 0), bad)
    with pytest.raises(ValueError, match="values have shape"):
        bottleneck4(np.ones((5, 4)), blocked, (0, 0), (1, 1))
    with pytest.raises(ValueError, match="non-empty 2-D"):
        bfs4(np.zeros(5, dtype=bool), (0, 0))


@needs_c
def test_the_c_functions_check_their_arguments():
    ck = native.extension()
    blocked = np.zeros((3, 3), dtype=bool)
    with pytest.raises(ValueError, match="bad grid"):
        ck.bfs4(blocked, 3, 3, 9)
    with pytest.raises(ValueError, match="bad grid"):
        ck.bottleneck4(np.zeros((3, 3)), blocked, 3, 3, 0, -1)
    with pytest.raises(ValueError, match="blocked"):
        ck.bfs4(blocked, 4, 4, 0)
    with pytest.raises(ValueError, match="values"):
        ck.bottleneck4(np.zeros((3, 3), dtype=np.float32), blocked, 3, 3, 0, 1)
