"""The compiled 8-connected A* behind :func:`ndrql.maps.astar.shortest_path8` (numba, ``cache=True``).

Importing this module imports numba, so :mod:`ndrql.maps.astar` imports it only when a search runs
(``import ndrql`` stays free of numba). The search is the pure-Python ``astar8`` step for step: the
open list is a binary heap held in arrays, ordered by ``(f, push counter)`` exactly like ``heapq``
on ``(f, counter, ...)`` tuples, ``f`` is computed with the same floating-point operations, and a
node is improved only when the new cost beats the old by more than ``1e-12``. The same pops happen
in the same order, so the path, the cost and the number of expanded nodes are identical. The C extension
``ndrql.maps._kernels`` holds a bit-identical port that runs instead when it is built (:mod:`ndrql.maps.native`).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

SQRT2 = math.sqrt(2.0)
_DR = np.array([-1, 1, 0, 0, -1, -1, 1, 1], dtype=np.int64)
_DC = np.array([0, 0, -1, 1, -1, 1, -1, 1], dtype=np.int64)
_STEP = np.array([1.0, 1.0, 1.0, 1.0, SQRT2, SQRT2, SQRT2, SQRT2], dtype=np.float64)


@nb.njit(cache=True)
def _less(f, cnt, i, j):
    """Heap order: smaller ``f``, then the earlier push (``heapq`` on ``(f, counter)``)."""
    return f[i] < f[j] or (f[i] == f[j] and cnt[i] < cnt[j])


@nb.njit(cache=True)
def _swap(f, cnt, g, node, i, j):
    f[i], f[j] = f[j], f[i]
    cnt[i], cnt[j] = cnt[j], cnt[i]
    g[i], g[j] = g[j], g[i]
    node[i], node[j] = node[j], node[i]


@nb.njit(cache=True)
def _sift_up(f, cnt, g, node, i):
    while i > 0:
        parent = (i - 1) >> 1
        if not _less(f, cnt, i, parent):
            break
        _swap(f, cnt, g, node, i, parent)
        i = parent


@nb.njit(cache=True)
def _sift_down(f, cnt, g, node, size):
    i = 0
    while True:
        left = 2 * i + 1
        if left >= size:
            break
        child = left
        if left + 1 < size and _less(f, cnt, left + 1, left):
            child = left + 1
        if not _less(f, cnt, child, i):
            break
        _swap(f, cnt, g, node, i, child)
        i = child


@nb.njit(cache=True)
def _grow(a, n):
    out = np.empty(2 * a.shape[0], dtype=a.dtype)
    out[:n] = a[:n]
    return out


@nb.njit(cache=True)
def astar8_kernel(blocked, s_idx, g_idx, corner_cutting):
    """A* on the 8-connected octile graph of ``blocked`` (2-D bool) between flat indices.

    Returns ``(path, cost, expanded)``: ``path`` the flat indices from start to goal (empty when the
    goal is unreachable), ``cost`` the octile length, ``expanded`` the nodes closed.
    """
    h, w = blocked.shape
    flat = blocked.ravel()
    n = h * w
    best = np.full(n, np.inf)
    parent = np.full(n, -1, dtype=np.int64)
    closed = np.zeros(n, dtype=np.bool_)
    gr, gc = g_idx // w, g_idx % w
    sr, sc = s_idx // w, s_idx % w
    cap = 1024
    hf = np.empty(cap)
    hcnt = np.empty(cap, dtype=np.int64)
    hg = np.empty(cap)
    hnode = np.empty(cap, dtype=np.int64)
    dh, dw = abs(sr - gr), abs(sc - gc)
    hf[0] = (SQRT2 - 1.0) * min(dh, dw) + max(dh, dw)
    hcnt[0] = 0
    hg[0] = 0.0
    hnode[0] = s_idx
    size = 1
    counter = 0
    best[s_idx] = 0.0
    expanded = 0
    while size > 0:
        gcost, idx = hg[0], hnode[0]
        size -= 1
        if size > 0:
            _swap(hf, hcnt, hg, hnode, 0, size)
            _sift_down(hf, hcnt, hg, hnode, size)
        if closed[idx]:
            continue
        closed[idx] = True
        expanded += 1
        if idx == g_idx:
            length = 0
            k = idx
            while k >= 0:
                length += 1
                k = parent[k]
            path = np.empty(length, dtype=np.int64)
            k = idx
            for i in range(length - 1, -1, -1):
                path[i] = k
                k = parent[k]
            return path, gcost, expanded
        r, c = idx // w, idx % w
        for m in range(8):
            dr, dc = _DR[m], _DC[m]
            nr, nc = r + dr, c + dc
            if nr < 0 or nr >= h or nc < 0 or nc >= w:
                continue
            nidx = nr * w + nc
            if flat[nidx] or closed[nidx]:
                continue
            if dr != 0 and dc != 0 and not corner_cutting and (flat[nr * w + c] or flat[r * w + nc]):
                continue
            ng = gcost + _STEP[m]
            if ng < best[nidx] - 1e-12:
                best[nidx] = ng
                parent[nidx] = idx
                counter += 1
                if size == hf.shape[0]:
                    hf, hcnt = _grow(hf, size), _grow(hcnt, size)
                    hg, hnode = _grow(hg, size), _grow(hnode, size)
                dh, dw = abs(nr - gr), abs(nc - gc)
                hf[size] = ng + (SQRT2 - 1.0) * min(dh, dw) + max(dh, dw)
                hcnt[size] = counter
                hg[size] = ng
                hnode[size] = nidx
                _sift_up(hf, hcnt, hg, hnode, size)
                size += 1
    return np.empty(0, dtype=np.int64), np.inf, expanded
