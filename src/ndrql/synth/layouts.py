"""Structured layouts of the map engine: perfect mazes, recursive division, building footprints.

Pure functions on numpy arrays (``True`` = obstacle, ``(row, col)``), every random choice from
the ``np.random.Generator`` passed in. The families in :mod:`ndrql.synth.families` combine them.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import minimum_spanning_tree

from ndrql.errors import NdrqlError
from ndrql.synth.shapes import paint_rects


def perfect_maze(rng: np.random.Generator, rows: int, cols: int, bias: float = 1.0) -> np.ndarray:
    """A perfect maze on a ``rows x cols`` cell grid, as a ``(2 rows + 1, 2 cols + 1)`` wall grid.

    Cells sit at odd ``(r, c)``, walls and wall joints elsewhere; ``True`` = wall. The passages form
    a spanning tree of the cells (every cell reachable by exactly one route): the minimum spanning
    tree under random edge weights (randomised Kruskal), horizontal weights scaled by ``bias``
    (``bias < 1`` favours long horizontal corridors, ``> 1`` vertical ones).
    """
    grid = np.ones((2 * rows + 1, 2 * cols + 1), dtype=bool)
    grid[1::2, 1::2] = False
    n = rows * cols
    if n < 2:
        return grid
    idx = np.arange(n).reshape(rows, cols)
    a = np.concatenate([idx[:, :-1].ravel(), idx[:-1, :].ravel()])
    b = np.concatenate([idx[:, 1:].ravel(), idx[1:, :].ravel()])
    n_h = rows * (cols - 1)
    weight = 1.0 - rng.random(a.size)  # in (0, 1]: a zero would drop the edge from the sparse graph
    weight[:n_h] *= bias
    tree = minimum_spanning_tree(coo_matrix((weight, (a, b)), shape=(n, n)).tocsr()).tocoo()
    u, v = np.minimum(tree.row, tree.col), np.maximum(tree.row, tree.col)
    grid[(u // cols) + (v // cols) + 1, (u % cols) + (v % cols) + 1] = False
    return grid


def expand_grid(coarse: np.ndarray, row_sizes: np.ndarray, col_sizes: np.ndarray) -> np.ndarray:
    """Blow each coarse cell ``(i, j)`` up to a ``row_sizes[i] x col_sizes[j]`` block of pixels."""
    return np.repeat(np.repeat(coarse, row_sizes, axis=0), col_sizes, axis=1)


def lattice_rows(height: int, width: int, corridor: int, wall: int) -> tuple[int, int]:
    """Cells of a maze lattice (corridor + wall pitch, a wall all round) that fit ``height x width``; raises
    :class:`~ndrql.errors.NdrqlError` when not even one does."""
    pitch = corridor + wall
    rows, cols = (height - wall) // pitch, (width - wall) // pitch
    if rows < 1 or cols < 1:
        raise NdrqlError(f"a {height}x{width} map has no room for a maze with corridor {corridor} and wall {wall}")
    return rows, cols


def place_lattice(rng: np.random.Generator, grid: np.ndarray, height: int, width: int, corridor: int,
                  wall: int) -> np.ndarray:
    """A maze wall grid (:func:`perfect_maze`) drawn with corridors ``corridor`` px and walls ``wall`` px wide, at a
    random offset on a ``height x width`` map whose pixels beside the lattice are wall."""
    rows, cols = (grid.shape[0] - 1) // 2, (grid.shape[1] - 1) // 2
    sizes = lambda n: np.array([wall] + [corridor, wall] * n)  # noqa: E731
    img = expand_grid(grid, sizes(rows), sizes(cols))
    out = np.ones((height, width), dtype=bool)
    r0 = int(rng.integers(0, height - img.shape[0] + 1))
    c0 = int(rng.integers(0, width - img.shape[1] + 1))
    out[r0:r0 + img.shape[0], c0:c0 + img.shape[1]] = img
    return out


def _valid_starts(bad: np.ndarray, lo: int, hi: int, span: int) -> np.ndarray:
    """Starts ``s`` in ``[lo, hi]`` such that ``bad[s - 1 : s + span + 1]`` holds no ``True``."""
    if hi < lo:
        return np.empty(0, dtype=np.int64)
    padded = np.concatenate([[0], np.cumsum(bad, dtype=np.int64)])
    s = np.arange(lo, hi + 1)
    a = np.clip(s - 1, 0, bad.size)
    b = np.clip(s + span + 1, 0, bad.size)
    return s[padded[b] - padded[a] == 0]


def _cut_doors(rng: np.random.Generator, obstacles: np.ndarray, doors: np.ndarray, wall: tuple[slice, slice],
               horizontal: bool, door: int, count: int) -> None:
    """Open ``count`` doors ``door`` pixels wide at random places along a wall, in place (marked in ``doors``)."""
    rs, cs = wall
    along = cs if horizontal else rs
    length = along.stop - along.start
    d = max(1, min(door, length))
    for _ in range(count):
        start = along.start + int(rng.integers(0, length - d + 1))
        span = slice(start, start + d)
        cut = (rs, span) if horizontal else (span, cs)
        obstacles[cut] = False
        doors[cut] = True


def recursive_division(rng: np.random.Generator, obstacles: np.ndarray, box: tuple[int, int, int, int], *,
                       room: int, wall: int, door: int, corridor: int = 0, corridor_p: float = 0.0,
                       stop_p: float = 0.2) -> None:
    """Divide the free box ``(r0, c0, r1, c1)`` of ``obstacles`` into rooms, in place.

    Recursive division: a region at least ``2 room + wall`` long is split by a wall ``wall`` px
    thick at a random position, with one or two doors ``door`` px wide; with probability
    ``corridor_p`` the split is a corridor ``corridor`` px wide between two walls with a door every
    ``2 room`` px, left undivided. A new wall never ends on a door of the walls it joins, so every
    room stays reachable. Regions shorter than ``3 room`` stop early with probability ``stop_p``.
    """
    doors = np.zeros(obstacles.shape, dtype=bool)
    h, w = obstacles.shape
    stack = [box]
    while stack:
        r0, c0, r1, c1 = stack.pop()
        hh, ww = r1 - r0, c1 - c0
        can = {True: hh >= 2 * room + wall, False: ww >= 2 * room + wall}
        if not (can[True] or can[False]) or (max(hh, ww) < 3 * room and rng.random() < stop_p):
            continue
        if can[True] and can[False]:
            first = hh > 1.2 * ww or (ww <= 1.2 * hh and rng.random() < 0.5)
        else:
            first = can[True]
        for horizontal in (first, not first):
            if not can[horizontal]:
                continue
            lo, hi, length = (r0, r1, hh) if horizontal else (c0, c1, ww)
            # Door pixels on the two walls this one would join, along the split axis.
            if horizontal:
                ends = [doors[:, c] for c in (c0 - 1, c1) if 0 <= c < w]
            else:
                ends = [doors[r, :] for r in (r0 - 1, r1) if 0 <= r < h]
            bad = np.logical_or.reduce(ends) if ends else np.zeros(h if horizontal else w, dtype=bool)
            corr = corridor > 0 and rng.random() < corridor_p and length >= 2 * room + 2 * wall + corridor
            span = 2 * wall + corridor if corr else wall
            starts = _valid_starts(bad, lo + room, hi - room - span, span)
            if starts.size == 0:
                continue
            p = int(starts[rng.integers(starts.size)])
            other = (c0, c1) if horizontal else (r0, r1)
            n_doors = max(1, (other[1] - other[0]) // (2 * room)) if corr else 1 + int(rng.random() < 0.15)
            walls = [p, p + wall + corridor] if corr else [p]
            for q in walls:
                sl = (slice(q, q + wall), slice(c0, c1)) if horizontal else (slice(r0, r1), slice(q, q + wall))
                obstacles[sl] = True
                _cut_doors(rng, obstacles, doors, sl, horizontal, door, n_doors)
            if horizontal:
                stack += [(r0, c0, p, c1), (p + span, c0, r1, c1)]
            else:
                stack += [(r0, c0, r1, p), (r0, p + span, r1, c1)]
            break


def rect_union_footprint(rng: np.random.Generator, shape: tuple[int, int], area: float, tries: int = 200) -> np.ndarray:
    """An irregular rectilinear building outline covering about ``area`` (a fraction) of ``shape``.

    A central rectangle (covering the map centre, so the outline reaches all four quadrants) grows
    by random rectangles (wings) that overlap it, until the covered fraction reaches ``area``; a
    wing that would overshoot ``area + 0.08`` is skipped.
    """
    h, w = shape
    fh, fw = rng.uniform(0.35, 0.6, size=2)
    r0 = int(h * rng.uniform(0.5 - fh + 0.05, 0.45))
    c0 = int(w * rng.uniform(0.5 - fw + 0.05, 0.45))
    out = paint_rects(shape, [(r0, c0, r0 + int(fh * h), c0 + int(fw * w))])
    covered = int(out.sum())
    for _ in range(tries):
        if covered >= area * h * w:
            break
        rh, rw = int(h * rng.uniform(0.1, 0.45)), int(w * rng.uniform(0.1, 0.45))
        a, b = int(rng.integers(-rh // 4, h - rh // 2)), int(rng.integers(-rw // 4, w - rw // 2))
        wing = out[max(a, 0):a + rh, max(b, 0):b + rw]
        new = wing.size - int(wing.sum())
        if new < wing.size and covered + new <= (area + 0.08) * h * w:  # overlaps the outline, no overshoot
            wing[...] = True
            covered += new
    return out
