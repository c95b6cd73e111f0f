"""Belief maps drawn from a true map: what a planner might know of it, three kinds, each from a seed.

Each generator takes the true obstacles (``True`` = obstacle, map resolution), start and goal in map
pixels and a :class:`numpy.random.Generator`, and returns a :class:`~ndrql.maps.belief.Belief` (the
obstacles the planner believes in, the pixels it does not know). Same map, same generator state, same
belief. Start and goal always stay known, with a small disc around each (``keep`` pixels; default
:func:`keep_radius`).

- :func:`blobs`: a target share (0.1, 0.3, 0.5) of the free space hidden in random blobs (irregular
  discs), exact to a pixel; obstacle pixels inside a blob are unknown too.
- :func:`sensed`: what a robot with sensing radius ``R`` saw driving along routes from its start
  (:func:`sensing_routes` draws them): a pixel is known when it lies within ``R`` of a route point with
  a line of sight (the first obstacle on a ray is seen, what lies behind it is not).
- :func:`outdated`: a wrong known map: some gaps and doors closed that are open in truth, some thin
  walls opened that are closed in truth; nothing unknown.

:data:`KINDS` names them for :func:`draw_belief`. These masks are the data of studies and of the
model that learns to plan on belief maps.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ndrql.maps.astar import shortest_path8
from ndrql.maps.belief import Belief

Point = tuple[int, int]

#: The kinds of belief :func:`draw_belief` draws.
KINDS = ("blobs", "sensed", "outdated")


def keep_radius(shape: Sequence[int]) -> float:
    """The radius of the disc kept known around start and goal: 4% of the longer side, at least 3 px."""
    return max(3.0, 0.04 * max(shape))


def disc(shape: Sequence[int], centre: Sequence[float], radius: float) -> np.ndarray:
    """Pixels within ``radius`` of ``centre`` (``(row, col)``)."""
    rr, cc = np.ogrid[:shape[0], :shape[1]]
    return (rr - centre[0]) ** 2 + (cc - centre[1]) ** 2 <= radius * radius


def kept(shape: Sequence[int], points: Sequence[Sequence[int]], radius: float | None) -> np.ndarray:
    """The discs kept known around ``points``."""
    r = keep_radius(shape) if radius is None else float(radius)
    out = np.zeros(tuple(shape), dtype=bool)
    for p in points:
        out |= disc(shape, p, r)
    return out


# ------------------------------------------------------------------------------------------------ blobs


def _blob_scale(shape: Sequence[int], centre: Sequence[int], r0: float, rng: np.random.Generator) -> np.ndarray:
    """Each pixel's distance from ``centre`` over the blob's radius in its direction (<= 1 inside): an
    irregular disc, its radius ``r0`` modulated by three random harmonics of the angle."""
    rr, cc = np.ogrid[:shape[0], :shape[1]]
    dr, dc = rr - centre[0], cc - centre[1]
    theta = np.arctan2(dr, dc)
    wobble = np.ones_like(theta)
    for k in (2, 3, 4):
        wobble = wobble + rng.uniform(0.0, 0.15) * np.cos(k * theta + rng.uniform(0.0, 2 * math.pi))
    return np.hypot(dr, dc) / (r0 * wobble)


def blobs(obstacles: np.ndarray, start: Point, goal: Point, fraction: float, rng: np.random.Generator, *,
          size: tuple[float, float] = (0.04, 0.12), keep: float | None = None) -> Belief:
    """Hide ``round(fraction x free pixels)`` free pixels (exactly) in random blobs, start and goal known.

    Blobs are irregular discs of radius ``size`` (a range, shares of the longer side) centred on free pixels
    still known; the last one is cut to the pixels nearest its centre so the count is exact. ``ValueError``
    when the discs kept around start and goal leave fewer free pixels than the target."""
    truth = np.asarray(obstacles, dtype=bool)
    if not 0.0 <= fraction < 1.0:
        raise ValueError(f"fraction must be in [0, 1), got {fraction}")
    shape = truth.shape
    keep_mask = kept(shape, (start, goal), keep)
    free = ~truth
    target = int(round(fraction * int(free.sum())))
    if target > int((free & ~keep_mask).sum()):
        raise ValueError(f"cannot hide {fraction:.0%} of the free space with start and goal kept visible")
    unknown = np.zeros(shape, dtype=bool)
    hidden_free = 0
    side = max(shape)
    while hidden_free < target:
        candidates = np.flatnonzero(free & ~unknown & ~keep_mask)
        centre = divmod(int(candidates[rng.integers(len(candidates))]), shape[1])
        scale = _blob_scale(shape, centre, rng.uniform(*size) * side, rng)
        inside = (scale <= 1.0) & ~keep_mask & ~unknown
        new_free = inside & free
        need = target - hidden_free
        if int(new_free.sum()) > need:  # the last blob: its `need` free pixels nearest the centre, obstacles within
            cut = np.sort(scale[new_free])[need - 1]
            inside &= scale <= cut
            new_free = inside & free
            if int(new_free.sum()) > need:  # ties at the cut: drop the extra ones in index order
                extra = np.flatnonzero(new_free & (scale == cut))[: int(new_free.sum()) - need]
                inside.flat[extra] = False
                new_free = inside & free
        unknown |= inside
        hidden_free += int(new_free.sum())
    return Belief(truth, unknown, kind="blobs")


# ------------------------------------------------------------------------------------------------ sensed


def ray_offsets(radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Offsets of the pixels within ``radius`` and, per offset, the pixels its ray from 0 passes before it
    (samples every half pixel, rounded; ``(N, K, 2)``, the end pixel repeated where the ray is shorter)."""
    r = int(math.floor(radius))
    dr, dc = np.mgrid[-r:r + 1, -r:r + 1]
    inside = dr ** 2 + dc ** 2 <= radius * radius
    off = np.stack([dr[inside], dc[inside]], axis=1)
    k = 2 * r + 2
    t = np.linspace(0.0, 1.0, k)[None, :, None]
    samples = np.rint(off[:, None, :] * t).astype(np.int64)
    return off, samples


def visible_from(obstacles: np.ndarray, point: Sequence[int], radius: float,
                 rays: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Pixels within ``radius`` of ``point`` that it sees: no obstacle pixel on the straight ray between them
    (the ray sampled every half pixel), the end pixel excluded (an obstacle is seen, what is behind it not)."""
    truth = np.asarray(obstacles, dtype=bool)
    h, w = truth.shape
    off, samples = rays if rays is not None else ray_offsets(radius)
    pr, pc = int(point[0]), int(point[1])
    sr, sc = samples[..., 0] + pr, samples[..., 1] + pc
    outside = (sr < 0) | (sr >= h) | (sc < 0) | (sc >= w)
    hit = np.where(outside, True, truth[np.clip(sr, 0, h - 1), np.clip(sc, 0, w - 1)])
    at_end = (samples[..., 0] == off[:, None, 0]) & (samples[..., 1] == off[:, None, 1])
    seen = ~(hit & ~at_end).any(axis=1)
    er, ec = off[:, 0] + pr, off[:, 1] + pc
    ok = seen & (er >= 0) & (er < h) & (ec >= 0) & (ec < w)
    out = np.zeros((h, w), dtype=bool)
    out[er[ok], ec[ok]] = True
    return out


def sensing_routes(obstacles: np.ndarray, start: Point, rng: np.random.Generator, count: int = 1,
                   min_share: float = 0.25) -> list[np.ndarray]:
    """``count`` routes a robot drove from ``start``: 8-connected shortest paths (in pixels) to free pixels
    drawn at random among those it can reach, at least ``min_share`` of the map's longer side away when any is."""
    truth = np.asarray(obstacles, dtype=bool)
    from scipy import ndimage  # lazy: scipy loads when a mask is drawn, not when plan imports the sensing

    labels, _ = ndimage.label(~truth)
    reach = labels == labels[start]
    rr, cc = np.nonzero(reach)
    far = np.hypot(rr - start[0], cc - start[1]) >= min_share * max(truth.shape)
    if far.any():
        rr, cc = rr[far], cc[far]
    routes = []
    for _ in range(count):
        i = int(rng.integers(len(rr)))
        routes.append(np.asarray(shortest_path8(truth, start, (int(rr[i]), int(cc[i]))).path, dtype=np.int64))
    return routes


def sensed(obstacles: np.ndarray, start: Point, goal: Point, routes: Sequence[np.ndarray], radius: float, *,
           keep: float | None = None, every: float | None = None) -> Belief:
    """What a robot with sensing radius ``radius`` (px) knows after driving ``routes`` (``(K, 2)`` pixel
    paths): the pixels it saw from a route point every ``every`` px (default ``radius / 4``, at least 1)
    by line of sight (:func:`visible_from`), and the discs around start and goal; the rest unknown."""
    truth = np.asarray(obstacles, dtype=bool)
    seen = kept(truth.shape, (start, goal), keep)
    rays = ray_offsets(radius)
    step = max(1.0, radius / 4 if every is None else float(every))
    for route in routes:
        pts = np.asarray(route, dtype=np.int64).reshape(-1, 2)
        if len(pts) == 0:
            continue
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
        marks = np.unique(np.searchsorted(arc, np.arange(0.0, arc[-1] + 1e-9, step)).clip(0, len(pts) - 1))
        for i in (*marks, len(pts) - 1):
            seen |= visible_from(truth, pts[i], radius, rays)
    return Belief(truth, ~seen, kind="sensed")


# ------------------------------------------------------------------------------------------------ outdated


def _runs(line: np.ndarray) -> list[tuple[int, int]]:
    """``(first, last)`` of every run of ``True`` in a 1-D array."""
    d = np.diff(np.concatenate([[0], line.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1))


def _bounded_runs(grid: np.ndarray, lo: int, hi: int) -> list[tuple[int, int, int]]:
    """``(row, first, last)`` of the runs of ``True`` along each row, ``lo..hi`` long, with ``False`` on
    both ends inside the array."""
    out = []
    w = grid.shape[1]
    for r in range(grid.shape[0]):
        for a, b in _runs(grid[r]):
            if lo <= b - a + 1 <= hi and a > 0 and b < w - 1:
                out.append((r, int(a), int(b)))
    return out


def _candidates(mask: np.ndarray, lo: int, hi: int) -> list[tuple[str, int, int, int]]:
    """Runs of ``mask`` across rows (``h``) and across columns (``v``), ``lo..hi`` long and bounded."""
    return [("h", *t) for t in _bounded_runs(mask, lo, hi)] + [("v", *t) for t in _bounded_runs(mask.T, lo, hi)]


def _span(shape: Sequence[int], run: tuple[str, int, int, int], depth: int) -> np.ndarray:
    """The pixels of a run, ``depth`` lines thick (centred on its line)."""
    axis, line, a, b = run
    out = np.zeros(tuple(shape), dtype=bool)
    lo, hi = line - depth // 2, line - depth // 2 + depth
    if axis == "h":
        out[max(0, lo):hi, a:b + 1] = True
    else:
        out[a:b + 1, max(0, lo):hi] = True
    return out


def _pick(cands: list, count: int, rng: np.random.Generator, avoid: np.ndarray, spacing: float,
          shape: Sequence[int], depth: int) -> list[np.ndarray]:
    """Up to ``count`` spans of random candidates, ``spacing`` px apart and clear of ``avoid``."""
    chosen: list[np.ndarray] = []
    centres: list[tuple[float, float]] = []
    for i in rng.permutation(len(cands)):
        if len(chosen) >= count:
            break
        axis, line, a, b = cands[int(i)]
        mid = (line, (a + b) / 2) if axis == "h" else ((a + b) / 2, line)
        if any(math.dist(mid, c) < spacing for c in centres):
            continue
        span = _span(shape, cands[int(i)], depth)
        if (span & avoid).any():
            continue
        chosen.append(span)
        centres.append(mid)
    return chosen


def outdated(obstacles: np.ndarray, start: Point, goal: Point, rng: np.random.Generator, *, closed: int = 3,
             opened: int = 3, gap: tuple[float, float] = (0.01, 0.08), wall: float = 0.03,
             keep: float | None = None) -> Belief:
    """A wrong known map: ``closed`` gaps (free runs across a row or column, ``gap`` long as shares of the
    longer side, obstacles on both ends) closed by a wall two pixels thick, and ``opened`` thin walls
    (obstacle runs at most ``wall`` of the side thick, free on both ends) opened by a door of the gap's
    largest width; none within the discs kept around start and goal, none closer than that width to
    another. Nothing is unknown: the belief is known and wrong (fewer changes when a map has fewer places)."""
    truth = np.asarray(obstacles, dtype=bool)
    shape = truth.shape
    side = max(shape)
    lo, hi = max(2, int(round(gap[0] * side))), max(3, int(round(gap[1] * side)))
    avoid = kept(shape, (start, goal), keep)
    belief = truth.copy()
    for span in _pick(_candidates(~truth, lo, hi), closed, rng, avoid, hi, shape, 2):
        belief |= span
    thick = max(1, int(round(wall * side)))
    for span in _pick(_candidates(truth, 1, thick), opened, rng, avoid, hi, shape, hi):
        belief &= ~(span & truth)
    return Belief(belief, np.zeros(shape, dtype=bool), kind="outdated")


def draw_belief(kind: str, obstacles: np.ndarray, start: Point, goal: Point, rng: np.random.Generator, *,
                fraction: float = 0.3, radius: float | None = None, routes: int = 3) -> Belief:
    """A belief of ``kind`` (:data:`KINDS`): ``blobs`` hides ``fraction``; ``sensed`` drives ``routes`` random
    routes with sensing radius ``radius`` px (default 10% of the longer side); ``outdated`` closes and opens."""
    if kind == "blobs":
        return blobs(obstacles, start, goal, fraction, rng)
    if kind == "sensed":
        truth = np.asarray(obstacles, dtype=bool)
        r = 0.1 * max(truth.shape) if radius is None else float(radius)
        return sensed(truth, start, goal, sensing_routes(truth, start, rng, routes), r)
    if kind == "outdated":
        return outdated(obstacles, start, goal, rng)
    raise ValueError(f"unknown kind of belief {kind!r}; valid: {', '.join(KINDS)}")


__all__ = ["KINDS", "blobs", "disc", "draw_belief", "keep_radius", "kept", "outdated", "ray_offsets", "sensed",
           "sensing_routes", "visible_from"]
