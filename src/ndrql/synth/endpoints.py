"""Start and goal pairs drawn like the path-planning dataset's.

Every dataset sample has its start in the top half of the rows (0..100 of 201), its goal in the
bottom half (100..200), the two in opposite column halves, at least 150 px apart (three quarters of
the map side), both on free pixels and joined by a path. :func:`sample_endpoints` draws pairs with
the same rules on a map of any size.

Halves share the middle row and column (for 201 px: rows 0..100 and 100..200), as in the dataset.
"Joined by a path" means an 8-connected path without corner cutting on the full map, which joins
exactly the pixels that 4-connected free space joins (a legal diagonal step always has both
orthogonal neighbours free), so one labelling of the 4-connected free components answers it.
"""

from __future__ import annotations

import math

import numpy as np

from ndrql.errors import NdrqlError

Point = tuple[int, int]


def _free_components(obstacles: np.ndarray) -> np.ndarray:
    """Labels of the 4-connected free components (0 on obstacles)."""
    from scipy.ndimage import label

    labels, _ = label(~obstacles)
    return labels


def sample_endpoints(
    rng: np.random.Generator, obstacles: np.ndarray, min_dist_frac: float = 0.75, tries: int = 200
) -> tuple[Point, Point] | None:
    """A ``(start, goal)`` pair of ``(row, col)`` points like the dataset's, or ``None``.

    The start is drawn uniformly from the free pixels of the top half of the rows; the goal
    uniformly from the free pixels of the bottom half that lie in the opposite column half, at a
    Euclidean distance of at least ``min_dist_frac * max(H, W)`` and in the start's free component.
    A start with no such goal is redrawn, up to ``tries`` times; ``None`` when none is found. Every
    draw comes from ``rng``: the same generator state gives the same pair.
    """
    obstacles = np.asarray(obstacles, dtype=bool)
    if obstacles.ndim != 2 or min(obstacles.shape) < 2:
        raise NdrqlError(f"sample_endpoints needs a 2-D map of at least 2x2 pixels, got shape {obstacles.shape}")
    if not (math.isfinite(min_dist_frac) and min_dist_frac >= 0):
        raise NdrqlError(f"min_dist_frac must be a finite number >= 0, got {min_dist_frac}")
    if int(tries) < 1:
        raise NdrqlError(f"tries must be >= 1, got {tries}")
    h, w = obstacles.shape
    mid_r, mid_c = (h - 1) / 2, (w - 1) / 2
    rows, cols = np.nonzero(~obstacles)
    top = np.flatnonzero(rows <= mid_r)
    bottom = np.flatnonzero(rows >= mid_r)
    if len(top) == 0 or len(bottom) == 0:
        return None
    comp = _free_components(obstacles)[rows, cols]
    b_rows, b_cols, b_comp = rows[bottom], cols[bottom], comp[bottom]
    min_dist2 = (min_dist_frac * max(h, w)) ** 2
    for _ in range(int(tries)):
        k = top[rng.integers(len(top))]
        sr, sc = int(rows[k]), int(cols[k])
        ok = b_comp == comp[k]
        if sc < mid_c:  # strictly left: the goal must be in the right half (middle column included)
            ok &= b_cols >= mid_c
        elif sc > mid_c:
            ok &= b_cols <= mid_c
        d2 = (b_rows - sr) ** 2 + (b_cols - sc) ** 2
        ok &= (d2 >= min_dist2) & (d2 > 0)
        candidates = np.flatnonzero(ok)
        if len(candidates):
            j = candidates[rng.integers(len(candidates))]
            return (sr, sc), (int(b_rows[j]), int(b_cols[j]))
    return None
