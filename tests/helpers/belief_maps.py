"""A small belief-map case shared by the tests of ``plan --hide``: a wall whose top the belief does not see."""

from __future__ import annotations

import numpy as np

START, GOAL = (5, 5), (5, 34)


def wall_map() -> np.ndarray:
    """40x40, a wall at column 20 from the top down to row 33 (the way round is at the bottom)."""
    o = np.zeros((40, 40), dtype=np.uint8)
    o[0:34, 20] = 1
    return o


def wall_mask() -> np.ndarray:
    """Hides the wall's top rows: the belief sees a short way across."""
    m = np.zeros((40, 40), dtype=np.uint8)
    m[0:12, 16:25] = 1
    return m
