"""Maps drawn to a fixed layout, not generated: an office floor plan with 8 px walls and 60 px doors, and a
map cut by a 1 px wall (the tests of real-map planning use them, and ``tools/real_maps_figures.py``
draws the office for docs/real-maps.md)."""

from __future__ import annotations

import numpy as np

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
