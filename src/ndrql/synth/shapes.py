"""Drawing primitives of the map engine: sizes, rectangles, stamps, traps and the openness test.

Everything here is a small pure function on numpy arrays (``True`` = obstacle, ``(row, col)``);
randomness comes only from the ``np.random.Generator`` passed in. The families in
:mod:`ndrql.synth.families` and the layouts in :mod:`ndrql.synth.layouts` are built from these.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np
from scipy import ndimage

from ndrql.errors import NdrqlError

#: 8-connectivity for :func:`scipy.ndimage.label`.
_EIGHT = np.ones((3, 3), dtype=bool)

#: Index arrays larger than this are stamped in chunks (bounds memory on 4096 px maps).
_STAMP_CHUNK = 1 << 22


def loguniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    """A value log-uniformly distributed in ``[lo, hi]`` (``lo`` when ``hi <= lo``)."""
    if hi <= lo:
        return float(lo)
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def feature_px(rng: np.random.Generator, extent: int, px: tuple[float, float], rel: tuple[float, float],
               given: int | None = None) -> int:
    """A feature size in pixels: ``given`` when the caller set it (nothing is drawn), else log-uniform over
    ``rel`` times ``extent``, that range clipped into ``px``.

    The relative range makes features grow with the map, the pixel range bounds them: a 2000 px map
    gets features that are relatively smaller than on a 201 px map where ``px[1]`` is reached, and
    relatively larger where ``px[0]`` is.
    """
    if given is not None:
        return given
    lo = min(max(rel[0] * extent, px[0]), px[1])
    hi = min(max(rel[1] * extent, px[0]), px[1])
    return max(1, int(round(loguniform(rng, lo, hi))))


def paint_rects(shape: tuple[int, int], rects: np.ndarray | Sequence[Sequence[int]]) -> np.ndarray:
    """Boolean mask of the union of half-open rectangles ``(r0, c0, r1, c1)``, clipped to ``shape``.

    A few rectangles are drawn by slicing, many small ones pixel by pixel (work proportional to
    their area), many large ones in one pass with a 2-D difference array (work proportional to the map).
    """
    h, w = shape
    r = np.asarray(rects, dtype=np.int64).reshape(-1, 4)
    r0, r1 = np.clip(r[:, 0], 0, h), np.clip(r[:, 2], 0, h)
    c0, c1 = np.clip(r[:, 1], 0, w), np.clip(r[:, 3], 0, w)
    keep = (r1 > r0) & (c1 > c0)
    r0, r1, c0, c1 = r0[keep], r1[keep], c0[keep], c1[keep]
    if r0.size <= 64:
        out = np.zeros(shape, dtype=bool)
        for a, b, c, d in zip(r0, c0, r1, c1):
            out[a:c, b:d] = True
        return out
    widths = c1 - c0
    areas = (r1 - r0) * widths
    total = int(areas.sum())
    if total <= h * w // 4:
        k = np.repeat(np.arange(r0.size), areas)
        offset = np.arange(total) - np.repeat(np.cumsum(areas) - areas, areas)
        out = np.zeros(shape, dtype=bool)
        out[r0[k] + offset // widths[k], c0[k] + offset % widths[k]] = True
        return out
    diff = np.zeros((h + 1, w + 1), dtype=np.int32)
    np.add.at(diff, (r0, c0), 1)
    np.add.at(diff, (r0, c1), -1)
    np.add.at(diff, (r1, c0), -1)
    np.add.at(diff, (r1, c1), 1)
    return diff.cumsum(axis=0).cumsum(axis=1)[:h, :w] > 0


def disc(diameter: int) -> np.ndarray:
    """Boolean footprint of a digital disc ``diameter`` pixels across (1 gives a single pixel)."""
    d = max(1, int(diameter))
    centre = (d - 1) / 2.0
    rr, cc = np.mgrid[0:d, 0:d]
    return (rr - centre) ** 2 + (cc - centre) ** 2 <= (d / 2.0) ** 2


def stamp(mask: np.ndarray, rows: np.ndarray, cols: np.ndarray, footprint: np.ndarray) -> None:
    """Set ``footprint`` (anchored at its top-left pixel) at every ``(rows[i], cols[i])`` of ``mask``, in place.

    Parts outside the mask are clipped. The work is proportional to the stamped pixels, not the map.
    """
    fr, fc = np.nonzero(footprint)
    h, w = mask.shape
    step = max(1, _STAMP_CHUNK // max(1, fr.size))
    rows = np.asarray(rows, dtype=np.int64)
    cols = np.asarray(cols, dtype=np.int64)
    for i in range(0, rows.size, step):
        rr = rows[i:i + step, None] + fr[None, :]
        cc = cols[i:i + step, None] + fc[None, :]
        ok = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
        mask[rr[ok], cc[ok]] = True


def trap_rects(box: tuple[int, int, int, int], thickness: int, opening: str, lip: float = 0.0) -> list[tuple[int, int, int, int]]:
    """Rectangles of a U-shaped bug trap in ``box = (r0, c0, r1, c1)``, open on side ``opening``.

    ``opening`` is one of ``"N"``, ``"S"``, ``"W"``, ``"E"``. Three sides are walls ``thickness``
    pixels thick; with ``lip > 0`` the open side keeps a wall of ``lip`` times its length at each
    end (a C shape whose mouth is the middle ``1 - 2 * lip``).
    """
    r0, c0, r1, c1 = box
    t = thickness
    sides = {
        "N": (r0, c0, r0 + t, c1),
        "S": (r1 - t, c0, r1, c1),
        "W": (r0, c0, r1, c0 + t),
        "E": (r0, c1 - t, r1, c1),
    }
    rects = [rect for side, rect in sides.items() if side != opening]
    if lip > 0:
        a, b, c, d = sides[opening]
        if opening in "NS":
            n = int(round(lip * (d - b)))
            rects += [(a, b, c, b + n), (a, d - n, c, d)]
        else:
            n = int(round(lip * (c - a)))
            rects += [(a, b, a + n, d), (c - n, b, c, d)]
    return rects


def largest_free_component(obstacles: np.ndarray) -> np.ndarray:
    """Mask of the largest 8-connected free component (all ``False`` when the map has no free pixel)."""
    labels, n = ndimage.label(~obstacles, structure=_EIGHT)
    if n == 0:
        return np.zeros(obstacles.shape, dtype=bool)
    counts = np.bincount(labels.ravel())
    counts[0] = 0
    return labels == int(np.argmax(counts))


def is_open(obstacles: np.ndarray) -> bool:
    """Whether long start/goal pairs exist: the largest 8-connected free component reaches opposite quadrants.

    It must touch the top-left and the bottom-right quadrant, or the top-right and the bottom-left
    one (so it spans both the top and bottom halves and both the left and right halves). Halves
    overlap in the middle row or column of an odd side, as the dataset's start and goal rows do.
    """
    big = largest_free_component(obstacles)
    h, w = big.shape
    top, bottom = slice(0, (h + 1) // 2), slice(h // 2, h)
    left, right = slice(0, (w + 1) // 2), slice(w // 2, w)
    tl, br = big[top, left].any(), big[bottom, right].any()
    tr, bl = big[top, right].any(), big[bottom, left].any()
    return bool((tl and br) or (tr and bl))


def carve_cross(obstacles: np.ndarray) -> np.ndarray:
    """A copy with a free plus-shaped corridor through the centre (the last-resort fix of a closed map)."""
    out = obstacles.copy()
    h, w = out.shape
    half = max(1, min(h, w) // 100)
    out[max(0, h // 2 - half): h // 2 + half + 1, :] = False
    out[:, max(0, w // 2 - half): w // 2 + half + 1] = False
    return out


def redraw_until_open(draw: Callable[[], np.ndarray], tries: int = 30) -> np.ndarray:
    """Call ``draw`` (which draws from its own generator) until :func:`is_open` holds, at most ``tries`` times.

    Deterministic for a seeded generator. If every try fails, the last draw gets a free cross
    through the centre (:func:`carve_cross`), so the result is always open.
    """
    obstacles = draw()
    for _ in range(tries - 1):
        if is_open(obstacles):
            return obstacles
        obstacles = draw()
    return obstacles if is_open(obstacles) else carve_cross(obstacles)


def check_range(name: str, value: float | None, lo: float, hi: float, integer: bool = False) -> None:
    """Raise :class:`~ndrql.errors.NdrqlError` unless ``value`` is ``None`` (randomised) or within ``[lo, hi]``.

    With ``integer`` the value must also be an integer (a pixel count or a number of things).
    """
    if value is None:
        return
    kinds = (int, np.integer) if integer else (int, float, np.integer, np.floating)
    if isinstance(value, bool) or not isinstance(value, kinds):
        raise NdrqlError(f"{name} must be {'an integer' if integer else 'a number'}, got {type(value).__name__}")
    if not lo <= value <= hi:
        raise NdrqlError(f"{name} must be in [{lo:g}, {hi:g}], got {value:g}")


def check_px(height: int, width: int, **sizes: int | None) -> None:
    """:func:`check_range` for feature sizes in pixels: each is ``None`` or an integer in 1..the longer side."""
    for name, value in sizes.items():
        check_range(name, value, 1, max(height, width), integer=True)


def redraw_oriented(rng: np.random.Generator, height: int, width: int,
                    plan: Callable[[int, int], np.ndarray]) -> np.ndarray:
    """``plan(h, w)`` in a random orientation (:func:`orient`), redrawn until open (:func:`redraw_until_open`)."""
    return redraw_until_open(lambda: orient(rng, height, width, plan))


def fill_to_density(shape: tuple[int, int], density: float, batch: Callable[[int], np.ndarray],
                    first: int, tol: float = 0.003) -> np.ndarray:
    """Union of ``batch(n)`` masks of ``n`` random items, topped up until the obstacle fraction reaches ``density``.

    Stops once the fraction is within ``tol`` below ``density`` (the last round may overshoot by
    about one item). After each round the coverage so far gives the items still needed (random
    items of mean area ``a`` cover ``1 - exp(-n a / A)`` of an area ``A``); 90 % of them are drawn,
    at most 12 rounds. ``batch`` draws from its own generator.
    """
    out = np.zeros(shape, dtype=bool)
    n_total, n = 0, max(1, first)
    for _ in range(12):
        out |= batch(n)
        n_total += n
        covered = float(out.mean())
        if covered >= density - tol or covered >= 0.999:
            break
        if covered <= 0.0:
            n *= 2
            continue
        need = n_total * np.log1p(-density) / np.log1p(-covered) - n_total
        n = max(1, int(0.9 * need))
    return out


def orient(rng: np.random.Generator, height: int, width: int, draw: Callable[[int, int], np.ndarray]) -> np.ndarray:
    """``draw(height, width)``, or with probability 1/2 ``draw(width, height)`` transposed: a random orientation."""
    if rng.random() < 0.5:
        return draw(height, width)
    return np.ascontiguousarray(draw(width, height).T)


def smooth_noise(rng: np.random.Generator, shape: tuple[int, int], cell: int) -> np.ndarray:
    """Smooth random field in [0, 1] (float32) whose blobs are about ``cell`` pixels across."""
    h, w = shape
    cell = max(1, int(cell))
    coarse = rng.random((-(-h // cell) + 1, -(-w // cell) + 1), dtype=np.float32)
    up = np.repeat(np.repeat(coarse, cell, axis=0), cell, axis=1)[:h, :w]
    return ndimage.uniform_filter(up, size=cell, mode="nearest")


def random_rects(rng: np.random.Generator, shape: tuple[int, int], n: int, side: int,
                  clusters: np.ndarray | None, bars: float) -> np.ndarray:
    """``n`` axis-aligned rectangles of typical side ``side``, a fraction ``bars`` of them long thin bars."""
    h, w = shape
    a = side * np.exp(rng.normal(0.0, 0.35, n))
    b = side * np.exp(rng.normal(0.0, 0.35, n))
    bar = rng.random(n) < bars
    a[bar] *= rng.uniform(3.0, 8.0, int(bar.sum()))
    b[bar] /= rng.uniform(2.0, 4.0, int(bar.sum()))
    flip = rng.random(n) < 0.5
    a, b = np.where(flip, b, a), np.where(flip, a, b)
    a, b = np.maximum(1, np.round(a)).astype(np.int64), np.maximum(1, np.round(b)).astype(np.int64)
    if clusters is None:
        cr, cc = rng.uniform(0, h, n), rng.uniform(0, w, n)
    else:
        k = rng.integers(len(clusters), size=n)
        spread = rng.uniform(0.04, 0.12) * max(h, w)
        cr, cc = clusters[k, 0] + rng.normal(0, spread, n), clusters[k, 1] + rng.normal(0, spread, n)
    r0, c0 = np.round(cr - a / 2).astype(np.int64), np.round(cc - b / 2).astype(np.int64)
    return paint_rects(shape, np.stack([r0, c0, r0 + a, c0 + b], axis=1))


def scatter_batch(rng: np.random.Generator, shape: tuple[int, int], n: int, size: int, squares: float) -> np.ndarray:
    """``n`` discs and squares (a fraction ``squares``) of diameters ``ceil(size / 4)``..``size`` at random places."""
    out = np.zeros(shape, dtype=bool)
    lo = max(1, (size + 3) // 4)
    sizes = rng.integers(lo, size + 1, n)
    square = rng.random(n) < squares
    rows = rng.integers(-size + 1, shape[0], n)
    cols = rng.integers(-size + 1, shape[1], n)
    for s in np.unique(sizes):
        for is_square in (False, True):
            pick = (sizes == s) & (square == is_square)
            if pick.any():
                foot = np.ones((s, s), dtype=bool) if is_square else disc(int(s))
                stamp(out, rows[pick], cols[pick], foot)
    return out


def trap_box(rng: np.random.Generator, h: int, w: int, size: float, area: str) -> tuple[int, int, int, int]:
    """Bounding box ``(r0, c0, r1, c1)`` of a bug trap of side ``size`` px centred in ``area`` ("top", "bottom", "any")."""
    bh = int(min(size, h - 8))
    bw = int(min(size * rng.uniform(0.75, 1.35), w - 8))
    rows = {"top": (0.12, 0.45), "bottom": (0.55, 0.88), "any": (0.1, 0.9)}[area]
    margin = max(3, min(h, w) // 50)
    r = int(np.clip(rng.uniform(*rows) * h - bh / 2, margin, max(margin, h - bh - margin)))
    c = int(np.clip(rng.uniform(0.1, 0.9) * w - bw / 2, margin, max(margin, w - bw - margin)))
    return r, c, r + bh, c + bw


def carve_segments(shape: tuple[int, int], segments: Sequence[tuple[Sequence[float], Sequence[float]]],
                   width: int) -> np.ndarray:
    """Mask of straight strokes ``width`` px wide (square pen) from ``p`` to ``q`` for each ``(p, q)`` in ``segments``."""
    rects = []
    half = (width - 1) // 2
    for p, q in segments:
        steps = int(max(abs(q[0] - p[0]), abs(q[1] - p[1]))) + 1
        r = np.rint(np.linspace(p[0], q[0], steps)).astype(np.int64) - half
        c = np.rint(np.linspace(p[1], q[1], steps)).astype(np.int64) - half
        rects.append(np.stack([r, c, r + width, c + width], axis=1))
    return paint_rects(shape, np.concatenate(rects) if rects else np.empty((0, 4), np.int64))


def join_free_areas(obstacles: np.ndarray, width: int, min_area: int, most: int = 64) -> np.ndarray:
    """Join free areas to the largest one, then fill what stays apart: every map of a family is one free area.

    Each 8-connected free component of at least ``min_area`` px (the ``most`` largest) gets a straight
    corridor ``width`` px wide from its pixel nearest to the largest component to that component
    (as that component was before any carving); free pixels still apart from the largest component
    afterwards become obstacles. Returns a new array.
    """
    out = np.array(obstacles, dtype=bool)
    labels, n = ndimage.label(~out, structure=_EIGHT)
    if n == 0:
        return out
    counts = np.bincount(labels.ravel())
    counts[0] = 0
    main = int(np.argmax(counts))
    others = [int(k) for k in np.argsort(-counts, kind="stable") if k not in (0, main) and counts[k] >= max(1, min_area)]
    if others:
        dist, (near_r, near_c) = ndimage.distance_transform_edt(labels != main, return_indices=True)
        segments = []
        for k in others[:most]:
            rows, cols = np.nonzero(labels == k)
            i = int(np.argmin(dist[rows, cols]))
            p = (rows[i], cols[i])
            segments.append((p, (near_r[p], near_c[p])))
        out &= ~carve_segments(out.shape, segments, width)
    return ~largest_free_component(out)
