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

The kernels are compiled with numba (``cache=True``); importing this module imports numba.
"""

from __future__ import annotations

import math
from typing import Sequence

import numba as nb
import numpy as np

from ndrql.errors import PointError
from ndrql.maps.astar import kernel_map

Point = Sequence[float]


#: Pixels the segment misses by less than this (in each axis, px) count as touched: float rounding
#: can then only ever add such a pixel, never drop a touched one.
EPS = 1e-9


@nb.njit(cache=True)
def _col_at(r0, c0, r1, c1, y):
    """Column of the segment at row ``y`` (exact at the end points and for dyadic inputs)."""
    if y == r0:
        return c0
    if y == r1:
        return c1
    return c0 + (y - r0) * (c1 - c0) / (r1 - r0)


@nb.njit(cache=True)
def _row_span(r0, c0, r1, c1, r):
    """Closed column interval of pixel row ``r`` touched by the segment (``lo > hi`` when none)."""
    y_lo = max(min(r0, r1), r - 0.5 - EPS)
    y_hi = min(max(r0, r1), r + 0.5 + EPS)
    if y_lo > y_hi:
        return 1, 0
    if r1 == r0:
        a, b = c0, c1
    elif r0 < r1:
        a, b = _col_at(r0, c0, r1, c1, y_lo), _col_at(r0, c0, r1, c1, y_hi)
    else:  # the same arithmetic whichever way the segment runs: the pixel set is symmetric
        a, b = _col_at(r1, c1, r0, c0, y_lo), _col_at(r1, c1, r0, c0, y_hi)
    c_lo, c_hi = min(a, b), max(a, b)
    return int(math.ceil(c_lo - 0.5 - EPS)), int(math.floor(c_hi + 0.5 + EPS))


@nb.njit(cache=True)
def _row_range(r0, r1):
    """Pixel rows touched, in the direction of travel: ``(first, last, step)``."""
    lo = int(math.ceil(min(r0, r1) - 0.5 - EPS))
    hi = int(math.floor(max(r0, r1) + 0.5 + EPS))
    if r1 >= r0:
        return lo, hi, 1
    return hi, lo, -1


@nb.njit(cache=True)
def _supercover(r0, c0, r1, c1):
    first, last, step = _row_range(r0, r1)
    count = 0
    r = first
    while True:
        lo, hi = _row_span(r0, c0, r1, c1, r)
        if hi >= lo:
            count += hi - lo + 1
        if r == last:
            break
        r += step
    out = np.empty((count, 2), dtype=np.int64)
    k = 0
    r = first
    while True:
        lo, hi = _row_span(r0, c0, r1, c1, r)
        if c1 >= c0:
            for c in range(lo, hi + 1):
                out[k, 0] = r
                out[k, 1] = c
                k += 1
        else:
            for c in range(hi, lo - 1, -1):
                out[k, 0] = r
                out[k, 1] = c
                k += 1
        if r == last:
            break
        r += step
    return out


@nb.njit(cache=True)
def _first_blocked(obstacles, r0, c0, r1, c1):
    """First pixel of the supercover (in travel order) that is an obstacle or off the map.

    Returns ``(found, row, col)``.
    """
    h, w = obstacles.shape
    first, last, step = _row_range(r0, r1)
    r = first
    while True:
        lo, hi = _row_span(r0, c0, r1, c1, r)
        if hi >= lo:
            if c1 >= c0:
                c, c_end, c_step = lo, hi, 1
            else:
                c, c_end, c_step = hi, lo, -1
            while True:
                if r < 0 or r >= h or c < 0 or c >= w or obstacles[r, c]:
                    return True, r, c
                if c == c_end:
                    break
                c += c_step
        if r == last:
            break
        r += step
    return False, 0, 0


@nb.njit(cache=True)
def _shortcut(obstacles, pts):
    n = pts.shape[0]
    keep = np.empty(n, dtype=np.int64)
    m = 0
    i = 0
    keep[m] = 0
    m += 1
    while i < n - 1:
        nxt = i + 1  # kept even when blocked: shortcutting never adds a collision, it cannot remove one
        for j in range(n - 1, i + 1, -1):
            blocked, _, _ = _first_blocked(obstacles, pts[i, 0], pts[i, 1], pts[j, 0], pts[j, 1])
            if not blocked:
                nxt = j
                break
        keep[m] = nxt
        m += 1
        i = nxt
    return keep[:m]


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
