"""The segment kernels of :mod:`ndrql.maps.lines` compiled with numba (``cache=True``): the reference.

Importing this module imports numba. :mod:`ndrql.maps.lines` runs the same kernels from the C extension
(``ndrql.maps._kernels``, bit-identical, tested) when it is built, and these only otherwise
(:mod:`ndrql.maps.native`). The supercover rule and :data:`EPS` are described in :mod:`ndrql.maps.lines`.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: The tolerance of :data:`ndrql.maps.lines.EPS` (the same value; a test checks).
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
