"""Maps drawn in code, not by the map families: an office floor plan with 8 px walls and 60 px doors, and a
map cut by a 1 px wall (the tests of real-map planning use them, and ``tools/real_maps_figures.py``
draws the office for docs/real-maps.md); and hand-made analogues of public benchmark maps drawn from a
seed (MovingAI-like mazes, rooms, game-like caves, ROS-like offices with doors and unknown space), with
far-apart start/goal pairs on them (the tests of ``--size auto`` and ``studies/plan_defaults/analogues.py``
use them).
"""

from __future__ import annotations

import numpy as np

from ndrql.errors import NoPathError
from ndrql.maps.astar import shortest_path8
from ndrql.maps.grid import GridMap

#: Start and goal of :func:`office_plan` (row, col): in the top-left room and the bottom-right room.
OFFICE_START = (300, 200)
OFFICE_GOAL = (1700, 1800)


def office_plan(side: int = 2000, wall: int = 8, door: int = 60) -> np.ndarray:
    """A ``side x side`` office floor plan (``True`` = wall): outer walls, a corridor across the middle
    (rows 900..1099), five rooms above and five below it separated by ``wall``-px walls, each room
    with one ``door``-px door into the corridor, and a desk block in every room."""
    m = np.zeros((side, side), dtype=bool)
    s = side / 2000
    w = wall
    m[:w, :] = m[-w:, :] = m[:, :w] = m[:, -w:] = True
    top, bottom = int(900 * s), int(1100 * s)
    m[top - w:top, :] = True  # corridor walls
    m[bottom:bottom + w, :] = True
    room = side // 5
    for k in range(1, 5):  # walls between rooms, above and below the corridor
        c = k * room
        m[:top, c - w // 2:c + w - w // 2] = True
        m[bottom:, c - w // 2:c + w - w // 2] = True
    for k in range(5):
        mid = k * room + room // 2
        m[top - w:top, mid - door // 2:mid + door - door // 2] = False  # doors into the corridor
        m[bottom:bottom + w, mid + room // 5 - door // 2:mid + room // 5 + door - door // 2] = False
        r0, c0 = int(450 * s), k * room + room // 4  # a desk in each room
        m[r0:r0 + int(120 * s), c0:c0 + room // 3] = True
        m[side - r0 - int(120 * s):side - r0, c0:c0 + room // 3] = True
    return m


def thin_wall_map(side: int = 400) -> np.ndarray:
    """A ``side x side`` map with one 1-px wall across the middle row and a 60 px opening at the right end."""
    m = np.zeros((side, side), dtype=bool)
    m[side // 2, : side - 60] = True
    return m


def maze(cells: int, corridor: int, wall: int, seed: int) -> np.ndarray:
    """A perfect maze (depth-first carving) of ``cells x cells`` rooms ``corridor`` px wide between walls
    ``wall`` px thick; ``True`` = obstacle."""
    rng = np.random.default_rng(seed)
    step = corridor + wall
    n = cells * step + wall
    occ = np.ones((n, n), dtype=bool)
    seen = np.zeros((cells, cells), dtype=bool)
    stack = [(0, 0)]
    seen[0, 0] = True
    occ[wall:wall + corridor, wall:wall + corridor] = False
    while stack:
        i, j = stack[-1]
        nxt = [(i + di, j + dj) for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))
               if 0 <= i + di < cells and 0 <= j + dj < cells and not seen[i + di, j + dj]]
        if not nxt:
            stack.pop()
            continue
        k = nxt[rng.integers(len(nxt))]
        seen[k] = True
        r0, c0 = wall + min(i, k[0]) * step, wall + min(j, k[1]) * step
        occ[r0:wall + max(i, k[0]) * step + corridor, c0:wall + max(j, k[1]) * step + corridor] = False
        stack.append(k)
    return occ


def rooms(n: int, room: int, door: int, seed: int) -> np.ndarray:
    """Square rooms ``room`` px wide behind 1 px walls, each wall with a door ``door`` px wide at a random place."""
    rng = np.random.default_rng(seed)
    occ = np.zeros((n, n), dtype=bool)
    for k in range(0, n, room):
        occ[k, :] = True
        occ[:, k] = True
    for k in range(0, n, room):
        for lo in range(0, n, room):
            hi = min(n, lo + room)
            if hi - lo > door + 2:
                d = int(rng.integers(lo + 1, hi - door))
                occ[k, d:d + door] = False
                occ[d:d + door, k] = False
    return occ


def cave(n: int, seed: int, fill: float = 0.45, steps: int = 5) -> np.ndarray:
    """A game-like cave: random fill smoothed by a cellular automaton (a cell becomes rock with >= 5 rock neighbours)."""
    rng = np.random.default_rng(seed)
    occ = rng.random((n, n)) < fill
    for _ in range(steps):
        p = np.pad(occ, 1, constant_values=True).astype(np.int8)
        nb = sum(p[1 + dr:1 + dr + n, 1 + dc:1 + dc + n] for dr in (-1, 0, 1) for dc in (-1, 0, 1)) - occ
        occ = nb >= 5
    return occ


def ros_office(h: int, w: int, resolution: float, door_m: float, seed: int) -> GridMap:
    """A ROS-like office: unknown space around the building (an obstacle, as the reader treats it), 0.1 m
    thick outer and inner walls, rooms with doors ``door_m`` wide, at ``resolution`` metres per pixel."""
    rng = np.random.default_rng(seed)
    occ = np.ones((h, w), dtype=bool)  # unknown
    m = max(2, int(round(1.0 / resolution)))
    occ[m:h - m, m:w - m] = False
    t = max(1, int(round(0.1 / resolution)))
    occ[m:m + t, m:w - m] = occ[h - m - t:h - m, m:w - m] = True
    occ[m:h - m, m:m + t] = occ[m:h - m, w - m - t:w - m] = True
    door = max(1, int(round(door_m / resolution)))
    mid = h // 2
    occ[mid:mid + t, m:w - m] = True  # a corridor wall with doors into the rooms
    for c in range(m + 2 * door, w - m - 2 * door, max(3 * door, (w - 2 * m) // 5)):
        occ[m:mid, c:c + t] = True  # room walls above the corridor wall
        d = int(rng.integers(m + t + 1, mid - door - 1))
        occ[d:d + door, c:c + t] = False  # a door between neighbouring rooms
        occ[mid:mid + t, c + t + 1:c + t + 1 + door] = False  # a door into the lower hall
    return GridMap(occ, source="drawn office", resolution=resolution, origin=(-w * resolution / 2, -h * resolution / 2, 0.0))


def free_pairs(occ: np.ndarray, k: int, seed: int) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """``k`` start/goal pairs of free pixels, far apart, drawn from ``seed`` (connected or not)."""
    rng = np.random.default_rng(seed)
    free = np.argwhere(~occ)
    out = []
    while len(out) < k:
        a, b = free[rng.integers(len(free), size=2)]
        if abs(int(a[0]) - int(b[0])) + abs(int(a[1]) - int(b[1])) > occ.shape[0] // 2:
            out.append(((int(a[0]), int(a[1])), (int(b[0]), int(b[1]))))
    return out


def connected(occ: np.ndarray, a: tuple[int, int], b: tuple[int, int]) -> bool:
    """Whether pixels ``a`` and ``b`` of ``occ`` are joined by an 8-connected path of free pixels."""
    try:
        shortest_path8(occ, a, b)
    except NoPathError:
        return False
    return True
