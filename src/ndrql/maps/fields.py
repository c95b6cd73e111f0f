"""Compiled fields over the 4-connected grid: move counts from a cell, and the widest path between two cells.

- :func:`bfs4`: the number of 4-connected moves from a source to every cell (what
  :func:`ndrql.maps.grid.bfs_distances` returns); O(cells). :func:`bfs4_filled`: the same as float64, with a
  value for every cell that cannot reach the source (the exact source's goal distance).
- :func:`bottleneck4`: the largest, over 4-connected paths through free cells from ``start`` to ``goal``, of the
  smallest value on the path (its ends included), the "widest path". The free cells with ``values > t`` join
  ``start`` and ``goal`` exactly when ``t < bottleneck4(...)``, so one call answers the question for every ``t`` at
  once (Eq. 7's threshold, :func:`ndrql.planning.priors.adaptive_threshold`); O(cells log cells).

They run the C extension when it is built, else numba's twins (:mod:`ndrql.maps.fields_kernel`; numpy on top of
:func:`bfs4` for :func:`bfs4_filled`); the choice is :mod:`ndrql.maps.native`'s, and both give the same answers.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ndrql.maps.native import c_kernels


def _cell(shape: tuple[int, int], cell: Sequence[int], name: str) -> int:
    """The flat index of ``cell`` on a grid of ``shape``; :class:`IndexError` when it is off the grid."""
    r, c = int(cell[0]), int(cell[1])
    h, w = shape
    if not (0 <= r < h and 0 <= c < w):
        raise IndexError(f"{name} ({r}, {c}) is off the {h}x{w} grid")
    return r * w + c


def _flags(blocked: np.ndarray) -> np.ndarray:
    """``blocked`` as the kernels take it: C-contiguous, read-only, bool, 2-D (no copy when it already is)."""
    out = np.ascontiguousarray(blocked, dtype=bool).view()
    if out.ndim != 2 or out.size == 0:
        raise ValueError(f"a grid must be a non-empty 2-D array, got shape {out.shape}")
    out.setflags(write=False)
    return out


def bfs4(blocked: np.ndarray, source: Sequence[int]) -> np.ndarray:
    """4-connected move counts from ``source`` to every cell through free cells, ``(h, w)`` int64; ``-1`` where a
    cell is unreachable or blocked (everywhere when ``source`` is blocked). :class:`IndexError` when ``source`` is
    off the grid."""
    flags = _flags(blocked)
    h, w = flags.shape
    src = _cell((h, w), source, "source")
    ck = c_kernels()
    if ck is None:
        from ndrql.maps.fields_kernel import bfs4_kernel  # lazy: loads numba

        return bfs4_kernel(flags, src).reshape(h, w)
    return np.frombuffer(ck.bfs4(flags, h, w, src), dtype=np.int64).reshape(h, w)


def bfs4_filled(blocked: np.ndarray, source: Sequence[int]) -> np.ndarray:
    """:func:`bfs4`'s move counts as float64, where every cell that cannot reach ``source`` (blocked ones included)
    takes the largest finite count (0 without one) plus its Manhattan distance to ``source``, added in that order:
    a goal distance that still orders the far cells sensibly. :class:`IndexError` when ``source`` is off the grid."""
    flags = _flags(blocked)
    h, w = flags.shape
    src = _cell((h, w), source, "source")
    kernel = getattr(c_kernels(), "far_field", None)  # None: no extension, or one built before this kernel
    if kernel is not None:
        return np.frombuffer(kernel(flags, h, w, src), dtype=np.float64).reshape(h, w)
    d = bfs4(flags, source).astype(np.float64)
    unreached = d < 0
    if unreached.any():
        rows = np.abs(np.arange(h, dtype=np.int64) - src // w)[:, None]
        cols = np.abs(np.arange(w, dtype=np.int64) - src % w)[None, :]
        d = np.where(unreached, (d.max() if not unreached.all() else 0.0) + rows + cols, d)
    return d


def bottleneck4(values: np.ndarray, blocked: np.ndarray, start: Sequence[int], goal: Sequence[int]) -> float:
    """The widest path's smallest value: the largest, over 4-connected paths through free cells from ``start`` to
    ``goal``, of the smallest of ``values`` along the path (``start`` and ``goal`` included). ``-inf`` when either
    end is blocked or they are not connected; a NaN cell counts as blocked (``NaN > t`` is false for every ``t``).

    For every ``t``: the free cells with ``values > t`` 4-connect ``start`` and ``goal`` if and only if
    ``t < bottleneck4(values, blocked, start, goal)``. :class:`IndexError` when an end is off the grid,
    :class:`ValueError` when the shapes differ.
    """
    flags = _flags(blocked)
    vals = np.ascontiguousarray(values, dtype=np.float64).view()
    vals.setflags(write=False)  # one numba compile for every caller's array (see ndrql.maps.astar.kernel_map)
    if vals.shape != flags.shape:
        raise ValueError(f"values have shape {vals.shape} but the grid is {flags.shape}")
    h, w = flags.shape
    s, g = _cell((h, w), start, "start"), _cell((h, w), goal, "goal")
    ck = c_kernels()
    if ck is None:
        from ndrql.maps.fields_kernel import bottleneck4_kernel  # lazy: loads numba

        return float(bottleneck4_kernel(vals, flags, s, g))
    return float(ck.bottleneck4(vals, flags, h, w, s, g))
