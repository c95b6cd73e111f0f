"""A* search: the optimality reference for every path metric.

- :func:`astar4`: 4-connected, unit cost, Manhattan heuristic, on the planning grid (docs/method.md:
  the optimal path length that Q-learning paths are compared against).
- :func:`astar8`: 8-connected with octile costs (diagonal = sqrt(2)) and no corner cutting (a
  diagonal move needs both orthogonal neighbours free), as in the MovingAI benchmarks.
- :func:`shortest_path8`: the same search compiled (the C extension, else numba's
  :mod:`ndrql.maps.astar_kernel`; :mod:`ndrql.maps.native` chooses), fast
  on 4000x4000 maps; it pops the same nodes in the same order, so path, cost and expansions are
  identical, and :func:`astar8` delegates to it.

The plain-Python searches are one best-first search over a table of moves (:func:`_best_first`).
All are deterministic (ties broken by insertion order), keep no state between calls, and raise
:class:`~ndrql.errors.NoPathError` when the goal cannot be reached.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ndrql.errors import NoPathError, PointError
from ndrql.maps.grid import MOVES4, Cell
from ndrql.maps.native import c_kernels

SQRT2 = math.sqrt(2.0)


@dataclass(frozen=True)
class AStarResult:
    """A shortest path found by A*."""

    path: list[Cell]
    """Cells from start to goal inclusive, as (row, col)."""
    cost: float
    """Path cost: number of moves for :func:`astar4`, octile length for :func:`astar8`."""
    expanded: int
    """Number of nodes expanded (popped and closed)."""

    @property
    def moves(self) -> int:
        """Number of moves (``len(path) - 1``)."""
        return len(self.path) - 1

    @property
    def length(self) -> float:
        """Alias of :attr:`cost` (moves for 4-connected search)."""
        return self.cost


#: Moves ``(d_row, d_col, cost)`` of the two searches, in the order they are tried (ties go to the earlier).
_MOVES4 = tuple((dr, dc, 1) for dr, dc in MOVES4)
_MOVES8 = _MOVES4 + ((-1, -1, SQRT2), (-1, 1, SQRT2), (1, -1, SQRT2), (1, 1, SQRT2))


def octile(a: Sequence[int], b: Sequence[int]) -> float:
    """Octile distance between two cells: the 8-connected cost on an empty map."""
    dr, dc = abs(a[0] - b[0]), abs(a[1] - b[1])
    return (SQRT2 - 1.0) * min(dr, dc) + max(dr, dc)


def _priority4(cost: float, cell: Sequence[int], goal: Sequence[int]) -> float:
    """``cost`` plus the Manhattan distance to ``goal``: the A* priority of :func:`astar4`."""
    return cost + abs(cell[0] - goal[0]) + abs(cell[1] - goal[1])


def _priority8(cost: float, cell: Sequence[int], goal: Sequence[int]) -> float:
    """``cost`` plus the octile distance to ``goal``, summed left to right as the compiled search
    (:mod:`ndrql.maps.astar_kernel`) sums it, so both order ties alike to the last bit."""
    dr, dc = abs(cell[0] - goal[0]), abs(cell[1] - goal[1])
    return cost + (SQRT2 - 1.0) * min(dr, dc) + max(dr, dc)


def _check_point(blocked: np.ndarray, point: Sequence[int], name: str) -> Cell:
    r, c = int(point[0]), int(point[1])
    h, w = blocked.shape
    if not (0 <= r < h and 0 <= c < w):
        raise PointError(f"{name} ({r}, {c}) is off the {h}x{w} grid")
    if blocked[r, c]:
        raise PointError(f"{name} ({r}, {c}) is on an obstacle")
    return (r, c)


def _reconstruct(parent: np.ndarray, goal_idx: int, w: int) -> list[Cell]:
    path = []
    idx = goal_idx
    while idx >= 0:
        path.append((idx // w, idx % w))
        idx = int(parent[idx])
    path.reverse()
    return path


def astar4(blocked: np.ndarray, start: Sequence[int], goal: Sequence[int]) -> AStarResult:
    """Shortest 4-connected path (unit moves) from ``start`` to ``goal`` avoiding ``blocked`` cells."""
    return _best_first(blocked, start, goal, _MOVES4, _priority4, corner_cutting=True, name="4-connected")


def kernel_map(obstacles: np.ndarray) -> np.ndarray:
    """``obstacles`` as the compiled kernels take it: a C-contiguous, read-only bool view (no copy when it
    already is one). Numba compiles one machine-code version per array type, and the writeable flag is
    part of the type: passing every map in one form means one compile on a fresh install, not two."""
    out = np.ascontiguousarray(obstacles, dtype=bool).view()
    out.setflags(write=False)
    return out


def shortest_path8(blocked: np.ndarray, start: Sequence[int], goal: Sequence[int]) -> AStarResult:
    """Shortest 8-connected path with octile costs and no corner cutting, compiled (C, or numba).

    A diagonal move ``(dr, dc)`` needs ``(r + dr, c)`` and ``(r, c + dc)`` free (MovingAI rule). Ties
    are broken by insertion order, so the result is deterministic. Raises
    :class:`~ndrql.errors.NoPathError` when the goal cannot be reached.
    """
    return _search8(blocked, start, goal, corner_cutting=False)


def shortest_path8_cells(blocked: np.ndarray, start: Sequence[int], goal: Sequence[int]) -> np.ndarray:
    """:func:`shortest_path8`'s path as an ``(K, 2)`` int64 array of ``(row, col)`` (no Python list in between:
    the exact source asks for one per plan)."""
    path, _, _, w = _search8_flat(blocked, start, goal, corner_cutting=False)
    return np.stack(np.divmod(path, w), axis=1)


def _search8(blocked: np.ndarray, start: Sequence[int], goal: Sequence[int], corner_cutting: bool) -> AStarResult:
    path, cost, expanded, w = _search8_flat(blocked, start, goal, corner_cutting)
    rows, cols = np.divmod(path, w)
    return AStarResult(list(zip(rows.tolist(), cols.tolist())), float(cost), int(expanded))


def _search8_flat(blocked: np.ndarray, start: Sequence[int], goal: Sequence[int],
                  corner_cutting: bool) -> tuple[np.ndarray, float, int, int]:
    """The compiled search: the path's flat cell indices (int64), its cost, the expansions and the grid's width."""
    blocked = kernel_map(blocked)
    h, w = blocked.shape
    s = _check_point(blocked, start, "start")
    g = _check_point(blocked, goal, "goal")
    ck = c_kernels()
    if ck is not None:  # the C kernel built at install time
        raw, cost, expanded = ck.astar8(blocked, h, w, s[0] * w + s[1], g[0] * w + g[1], bool(corner_cutting))
        path = np.frombuffer(raw, dtype=np.int64)
    else:  # numba's, imported here, not at the top: ``import ndrql.maps`` must not import numba (start-up time)
        from ndrql.maps.astar_kernel import astar8_kernel  # lazy: loads numba

        path, cost, expanded = astar8_kernel(blocked, s[0] * w + s[1], g[0] * w + g[1], bool(corner_cutting))
    if len(path) == 0:
        raise NoPathError(f"no 8-connected path from start {s} to goal {g}")
    return np.asarray(path, dtype=np.int64), cost, expanded, w


def astar8(
    blocked: np.ndarray, start: Sequence[int], goal: Sequence[int], corner_cutting: bool = False
) -> AStarResult:
    """Shortest 8-connected path with octile costs; no corner cutting unless ``corner_cutting``.

    Without corner cutting a diagonal move ``(dr, dc)`` needs ``(r + dr, c)`` and ``(r, c + dc)`` free
    (MovingAI benchmark rule). ``cost`` is the octile length, comparable to a ``.scen`` optimal length.
    Runs the compiled search of :func:`shortest_path8`; :func:`_astar8_python` is the same search in
    plain Python, kept as the reference the tests compare against.
    """
    return _search8(blocked, start, goal, corner_cutting)


def _astar8_python(
    blocked: np.ndarray, start: Sequence[int], goal: Sequence[int], corner_cutting: bool = False
) -> AStarResult:
    """Pure-Python reference of :func:`astar8` (same pops in the same order)."""
    return _best_first(blocked, start, goal, _MOVES8, _priority8, corner_cutting, name="8-connected")


def _best_first(blocked: np.ndarray, start: Sequence[int], goal: Sequence[int], moves: Sequence[tuple[int, int, float]],
                priority: Callable[[float, Sequence[int], Sequence[int]], float], corner_cutting: bool,
                name: str) -> AStarResult:
    """A* in plain Python over ``moves``, ``priority(cost, cell, goal)`` = cost so far plus an admissible
    heuristic: :func:`astar4` and the reference of :func:`astar8`. Ties on the priority go to the node
    pushed first; a diagonal move needs both orthogonal neighbours free unless ``corner_cutting``."""
    blocked = np.asarray(blocked, dtype=bool)
    h, w = blocked.shape
    s = _check_point(blocked, start, "start")
    g = _check_point(blocked, goal, "goal")
    flat_blocked = blocked.ravel()
    best = np.full(h * w, np.inf, dtype=np.float64)
    parent = np.full(h * w, -1, dtype=np.int64)
    closed = np.zeros(h * w, dtype=bool)
    s_idx = s[0] * w + s[1]
    g_idx = g[0] * w + g[1]
    best[s_idx] = 0.0
    counter = 0
    heap = [(priority(0, s, g), counter, 0, s_idx)]
    expanded = 0
    while heap:
        _, _, gcost, idx = heapq.heappop(heap)
        if closed[idx]:
            continue
        closed[idx] = True
        expanded += 1
        if idx == g_idx:
            return AStarResult(_reconstruct(parent, g_idx, w), float(gcost), expanded)
        r, c = divmod(idx, w)
        for dr, dc, step in moves:
            nr, nc = r + dr, c + dc
            if not (0 <= nr < h and 0 <= nc < w):
                continue
            nidx = nr * w + nc
            if flat_blocked[nidx] or closed[nidx]:
                continue
            if dr and dc and not corner_cutting and (flat_blocked[nr * w + c] or flat_blocked[r * w + nc]):
                continue
            ng = gcost + step
            if ng < best[nidx] - 1e-12:
                best[nidx] = ng
                parent[nidx] = idx
                counter += 1
                heapq.heappush(heap, (priority(ng, (nr, nc), g), counter, ng, nidx))
    raise NoPathError(f"no {name} path from start {s} to goal {g}")


def path_is_valid(blocked: np.ndarray, path: Sequence[Sequence[int]], diagonal: bool = False, corner_cutting: bool = False) -> bool:
    """Whether ``path`` stays on free cells and each step is one legal move (4- or 8-connected)."""
    blocked = np.asarray(blocked, dtype=bool)
    h, w = blocked.shape
    for r, c in path:
        if not (0 <= r < h and 0 <= c < w) or blocked[r, c]:
            return False
    for (r0, c0), (r1, c1) in zip(path, path[1:]):
        dr, dc = r1 - r0, c1 - c0
        if abs(dr) + abs(dc) == 1:
            continue
        if not (diagonal and abs(dr) == 1 and abs(dc) == 1):
            return False
        if not corner_cutting and (blocked[r0 + dr, c0] or blocked[r0, c0 + dc]):
            return False
    return True
