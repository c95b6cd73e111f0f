"""Straight segments on a pixel grid: supercover, line of sight, polyline collisions, shortcutting.

Pixel ``(r, c)`` has its centre at ``(r, c)`` and covers the closed square
``[r - 0.5, r + 0.5] x [c - 0.5, c + 0.5]``. The *supercover* of a segment is every pixel whose
closed square the segment touches, corner touches included: a segment through a pixel corner
covers all the pixels that share that corner, and a segment running along a pixel edge covers the
pixels on both sides. A segment is *free* when no pixel of its supercover is an obstacle or off
the map, which makes line of sight conservative.

How the supercover is computed: the segment is cut at the horizontal pixel boundaries
``r +- 0.5``; inside each pixel row the cut piece spans a closed column interval ``[c_lo, c_hi]``,
and the row's pixels are those whose closed column interval meets it (a row-by-row variant of
Amanatides and Woo's grid traversal that decides ties explicitly). A column on a boundary is the end
point's own column when the boundary is an end point, else ``c0 + (y - r0) * dc / dr`` in that
order, so when the true value is representable (a corner crossing with integer or half-integer end
points, an end point on a pixel edge) the result is exactly that number and every pixel sharing
the corner or edge is included. For arbitrary floats, rounding is absorbed by a tolerance of
:data:`EPS` (1e-9 px): a pixel the segment misses by less than that may be included, a touched one
is never left out. Pixels come out in the order the segment reaches them (rows from ``p0`` to
``p1``, and within a row columns in the direction of travel).

The kernels run compiled: from the C extension built at install time, else with numba
(:mod:`ndrql.maps.native` chooses; :mod:`ndrql.maps.lines_kernel` holds numba's). Importing this module
imports neither.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ndrql.errors import PointError
from ndrql.maps.astar import kernel_map
from ndrql.maps.native import c_kernels

Point = Sequence[float]


#: Pixels the segment misses by less than this (in each axis, px) count as touched: float rounding
#: can then only ever add such a pixel, never drop a touched one.
EPS = 1e-9


def _first_blocked(obstacles: np.ndarray, r0: float, c0: float, r1: float, c1: float) -> tuple[bool, int, int]:
    """First pixel of the supercover (in travel order) that is an obstacle or off the map: ``(found, row, col)``.

    ``obstacles`` as :func:`~ndrql.maps.astar.kernel_map` returns it. Runs the C kernel, or numba's
    (:mod:`ndrql.maps.native`).
    """
    ck = c_kernels()
    if ck is None:
        from ndrql.maps.lines_kernel import _first_blocked as numba_first_blocked  # lazy: loads numba

        return numba_first_blocked(obstacles, r0, c0, r1, c1)
    h, w = obstacles.shape
    return ck.first_blocked(obstacles, h, w, r0, c0, r1, c1)


def _shortcut(obstacles: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Indices of the points :func:`shortcut` keeps (``pts`` float64, C-contiguous ``(N, 2)``)."""
    ck = c_kernels()
    if ck is None:
        from ndrql.maps.lines_kernel import _shortcut as numba_shortcut  # lazy: loads numba

        return numba_shortcut(obstacles, pts)
    h, w = obstacles.shape
    return np.frombuffer(ck.shortcut(obstacles, h, w, pts), dtype=np.int64)


def _supercover(r0: float, c0: float, r1: float, c1: float) -> np.ndarray:
    """The supercover as ``(K, 2)`` int64 ``(row, col)``, in travel order."""
    ck = c_kernels()
    if ck is None:
        from ndrql.maps.lines_kernel import _supercover as numba_supercover  # lazy: loads numba

        return numba_supercover(r0, c0, r1, c1)
    return np.frombuffer(ck.supercover(r0, c0, r1, c1), dtype=np.int64).reshape(-1, 2)


def _xy(p: Point) -> tuple[float, float]:
    r, c = float(p[0]), float(p[1])
    if not (math.isfinite(r) and math.isfinite(c)):
        raise PointError(f"segment end point ({r}, {c}) is not finite")
    return r, c


def segment_pixels(p0: Point, p1: Point) -> np.ndarray:
    """The supercover of the segment ``p0 -> p1`` as a ``(K, 2)`` int array of ``(row, col)``.

    Every pixel whose closed square the segment touches, corner touches included, in the order the
    segment reaches them. A degenerate segment (``p0 == p1``) gives the pixels that contain the point
    (up to 4 when it lies on a corner).
    """
    r0, c0 = _xy(p0)
    r1, c1 = _xy(p1)
    return _supercover(r0, c0, r1, c1)


def segment_free(obstacles: np.ndarray, p0: Point, p1: Point) -> bool:
    """Whether no pixel of the segment's supercover is an obstacle or off the map."""
    r0, c0 = _xy(p0)
    r1, c1 = _xy(p1)
    blocked, _, _ = _first_blocked(kernel_map(obstacles), r0, c0, r1, c1)
    return not blocked


def polyline_collisions(obstacles: np.ndarray, points: Sequence[Point] | np.ndarray) -> list[tuple[int, tuple[int, int]]]:
    """For each segment ``i`` (``points[i] -> points[i + 1]``) that is not free: ``(i, first blocked pixel)``.

    The first blocked pixel is the first pixel of the supercover, in travel order, that is an
    obstacle or off the map (it may then lie outside the map).
    """
    obstacles = kernel_map(obstacles)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    out: list[tuple[int, tuple[int, int]]] = []
    for i in range(len(pts) - 1):
        blocked, r, c = _first_blocked(obstacles, pts[i, 0], pts[i, 1], pts[i + 1, 0], pts[i + 1, 1])
        if blocked:
            out.append((i, (int(r), int(c))))
    return out


def shortcut(obstacles: np.ndarray, points: Sequence[Point] | np.ndarray) -> np.ndarray:
    """Greedy line-of-sight shortcutting of a polyline; returns the kept points ``(M, 2)``.

    Keeps the first point; from the current kept point jumps to the farthest later point whose
    segment is free (:func:`segment_free`); keeps the last point. An input segment that is itself
    blocked is kept as it is (there is no free jump past it), so the output never has a collision
    the input did not have: on a collision-free input every output segment is free. The output is
    never longer than the input (triangle inequality) and has the dtype of the input points.
    """
    obstacles = kernel_map(obstacles)
    pts = np.asarray(points)
    if pts.ndim != 2 or pts.shape[1] != 2:
        pts = pts.reshape(-1, 2)
    if len(pts) <= 2:
        return pts.copy()
    keep = _shortcut(obstacles, np.ascontiguousarray(pts, dtype=np.float64))
    return pts[keep].copy()


def polyline_length(points: Sequence[Point] | np.ndarray) -> float:
    """Euclidean length of the polyline through ``points`` (sum of its segment lengths)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(pts) < 2:
        return 0.0
    return float(np.hypot(*np.diff(pts, axis=0).T).sum())


def crosses_itself(points: Sequence[Point] | np.ndarray, fold: float = 1.5, eps: float = 1e-9) -> bool:
    """Whether the polyline through ``points`` meets itself: two segments that are not neighbours along it
    touch or cross, or two neighbours fold back over each other by more than ``fold`` pixels (a path that
    goes back the way it came; a shorter fold, such as an unsmoothed path's step from its start pixel back to
    its cell's centre, is not a loop). ``O(n^2)`` in the segments, vectorised per segment."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    pts = pts[np.r_[True, np.any(np.diff(pts, axis=0) != 0, axis=1)]]  # repeated points are not loops
    a, b = pts[:-1], pts[1:]
    n = len(a)
    if n >= 2:  # a neighbour folding back: the turn between consecutive segments is 180 degrees
        d0, d1 = b[:-1] - a[:-1], b[1:] - a[1:]
        cross = d0[:, 0] * d1[:, 1] - d0[:, 1] * d1[:, 0]
        overlap = np.minimum(np.hypot(*d0.T), np.hypot(*d1.T))
        if np.any((np.abs(cross) <= eps) & ((d0 * d1).sum(1) < 0) & (overlap > fold)):
            return True

    def orient(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
        v = (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0])
        return np.where(np.abs(v) <= eps, 0.0, np.sign(v))

    def on(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:  # r on segment pq, given collinear
        return ((np.minimum(p[..., 0], q[..., 0]) - eps <= r[..., 0]) & (r[..., 0] <= np.maximum(p[..., 0], q[..., 0]) + eps)
                & (np.minimum(p[..., 1], q[..., 1]) - eps <= r[..., 1]) & (r[..., 1] <= np.maximum(p[..., 1], q[..., 1]) + eps))

    for i in range(n - 2):
        p, q = a[i], b[i]
        r, s = a[i + 2:], b[i + 2:]
        o1, o2, o3, o4 = orient(p, q, r), orient(p, q, s), orient(r, s, p), orient(r, s, q)
        hit = (o1 * o2 < 0) & (o3 * o4 < 0)
        hit |= (o1 == 0) & on(p, q, r)
        hit |= (o2 == 0) & on(p, q, s)
        hit |= (o3 == 0) & on(r, s, np.broadcast_to(p, r.shape))
        hit |= (o4 == 0) & on(r, s, np.broadcast_to(q, r.shape))
        if np.any(hit):
            return True
    return False
