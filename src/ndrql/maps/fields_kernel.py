"""The compiled grid fields behind :mod:`ndrql.maps.fields` (numba, ``cache=True``): the reference and the fallback.

Importing this module imports numba, so :mod:`ndrql.maps.fields` imports it only when the C extension
``ndrql.maps._kernels`` is missing or ``NDRQL_KERNELS=numba`` (:mod:`ndrql.maps.native`). The extension holds
line-for-line ports of both kernels with the same answers.

- :func:`bfs4_kernel`: 4-connected move counts from one cell (a breadth-first search over an array queue);
- :func:`bottleneck4_kernel`: the widest path between two cells, i.e. the largest, over 4-connected paths
  through free cells, of the smallest value on the path (a maxi-min Dijkstra over a binary max-heap).
"""

from __future__ import annotations

import numba as nb
import numpy as np

_DR4 = np.array([-1, 1, 0, 0], dtype=np.int64)
_DC4 = np.array([0, 0, -1, 1], dtype=np.int64)


@nb.njit(cache=True)
def bfs4_kernel(blocked, src):
    """Move counts (int64, flat ``h * w``) from flat cell ``src`` through free cells of ``blocked`` (2-D bool);
    -1 where unreachable or blocked."""
    h, w = blocked.shape
    flat = blocked.ravel()
    n = h * w
    dist = np.full(n, -1, dtype=np.int64)
    if flat[src]:
        return dist
    queue = np.empty((n, 2), dtype=np.int64)  # (row, col) pairs: no division per cell
    head, tail = 0, 1
    dist[src] = 0
    queue[0, 0], queue[0, 1] = src // w, src % w
    while head < tail:
        r, c = queue[head, 0], queue[head, 1]
        head += 1
        d = dist[r * w + c] + 1
        for m in range(4):
            nr, nc = r + _DR4[m], c + _DC4[m]
            if nr < 0 or nr >= h or nc < 0 or nc >= w:
                continue
            nidx = nr * w + nc
            if dist[nidx] < 0 and not flat[nidx]:
                dist[nidx] = d
                queue[tail, 0], queue[tail, 1] = nr, nc
                tail += 1
    return dist


@nb.njit(cache=True)
def _push(key, node, size, k, v):
    """Put ``(k, v)`` into the max-heap of ``size`` entries (the arrays have room); sift up."""
    i = size
    while i > 0:
        parent = (i - 1) >> 1
        if not key[parent] < k:
            break
        key[i] = key[parent]
        node[i] = node[parent]
        i = parent
    key[i] = k
    node[i] = v


@nb.njit(cache=True)
def _pop(key, node, size):
    """Remove the top of the max-heap of ``size`` entries (``size >= 1``); sift the last entry down."""
    size -= 1
    k, v = key[size], node[size]
    i = 0
    while True:
        child = 2 * i + 1
        if child >= size:
            break
        if child + 1 < size and key[child] < key[child + 1]:
            child += 1
        if not k < key[child]:
            break
        key[i] = key[child]
        node[i] = node[child]
        i = child
    if size > 0:
        key[i] = k
        node[i] = v


@nb.njit(cache=True)
def bottleneck4_kernel(values, blocked, s, g):
    """The widest path's smallest value between flat cells ``s`` and ``g`` (``values`` 2-D float64, ``blocked``
    2-D bool): ``-inf`` when an end is blocked or NaN or they are not 4-connected. NaN cells count as blocked."""
    h, w = blocked.shape
    flat = blocked.ravel()
    vals = values.ravel()
    n = h * w
    if flat[s] or flat[g] or vals[s] != vals[s] or vals[g] != vals[g]:
        return -np.inf
    best = np.full(n, -np.inf)
    closed = np.zeros(n, dtype=np.bool_)
    key = np.empty(1024)
    node = np.empty(1024, dtype=np.int64)
    best[s] = vals[s]
    _push(key, node, 0, vals[s], s)
    size = 1
    while size > 0:
        top, idx = key[0], node[0]
        _pop(key, node, size)
        size -= 1
        if closed[idx]:
            continue
        closed[idx] = True
        if idx == g:
            return top
        r, c = idx // w, idx % w
        for m in range(4):
            nr, nc = r + _DR4[m], c + _DC4[m]
            if nr < 0 or nr >= h or nc < 0 or nc >= w:
                continue
            nidx = nr * w + nc
            v = vals[nidx]
            if closed[nidx] or flat[nidx] or v != v:
                continue
            k = v if v < top else top
            if k > best[nidx]:
                best[nidx] = k
                if size == key.shape[0]:
                    grown_key = np.empty(2 * size)
                    grown_node = np.empty(2 * size, dtype=np.int64)
                    grown_key[:size] = key
                    grown_node[:size] = node
                    key, node = grown_key, grown_node
                _push(key, node, size, k, nidx)
                size += 1
    return -np.inf
