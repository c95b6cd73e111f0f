"""Procedural map families: the dataset's kinds of maps and new ones, at any size.

Each family is a small pure function ``generate(rng, height, width, **params) -> obstacles``
(``bool``, ``True`` = obstacle, shape ``(height, width)``) that draws every random choice from
``rng``: the same generator state gives the same map. Parameters left at ``None`` are randomised
per draw, and every family randomises its scale: feature sizes are drawn from ranges given both in
pixels and relative to the map, so a 2000 px map is not a 201 px map scaled up. Every map leaves a
large open area: the largest 8-connected free component reaches two opposite quadrants
(:func:`ndrql.synth.shapes.is_open`); a draw that fails this is redrawn from the same generator.

:data:`FAMILIES` maps a name to a :class:`Family`; :func:`generate_map` looks a family up by name
and checks its arguments. The building-like families (``office``, ``warehouse``, ``ros_scan``)
are written in :mod:`ndrql.synth.buildings`.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ndrql.errors import NdrqlError
from ndrql.maps.grid import MODEL_SIDE
from ndrql.synth.buildings import office, ros_scan, warehouse
from ndrql.synth.cities import city, corridor_maze, dungeon, floor
from ndrql.synth.layouts import lattice_rows, perfect_maze, place_lattice, recursive_division
from ndrql.synth.natural import cave, outdoor
from ndrql.synth.shapes import (check_px, check_range, disc, feature_px, fill_to_density, loguniform, paint_rects,
                                random_rects, redraw_oriented, redraw_until_open, scatter_batch, trap_box, trap_rects)

#: Smallest map side :func:`generate_map` accepts.
MIN_SIDE = 16


def _blocks_once(rng: np.random.Generator, h: int, w: int, density: float | None, size: int | None) -> np.ndarray:
    side = feature_px(rng, max(h, w), px=(4, 500), rel=(0.004, 0.15), given=size)
    d = density if density is not None else rng.uniform(0.08, 0.3)
    clusters = rng.uniform(0, 1, (int(rng.integers(2, 7)), 2)) * (h, w) if rng.random() < 0.5 else None
    bars = rng.uniform(0.0, 0.3)
    first = int(0.7 * -np.log1p(-d) * h * w / side**2) + 1
    return fill_to_density((h, w), d, lambda n: random_rects(rng, (h, w), n, side, clusters, bars), first, tol=0.015)


def blocks(rng: np.random.Generator, height: int, width: int, *, density: float | None = None,
           size: int | None = None) -> np.ndarray:
    """Random axis-aligned rectangles, clustered on half the maps, some of them long thin bars.

    Randomises the obstacle fraction ``density`` (0.08-0.30, met to within 0.015), the typical
    block ``size`` (0.4-15 % of the longer side, clipped to 4-500 px; each block's sides vary by a
    factor of about 1.4), clustering (2-6 clusters on half the maps) and the share of bars (0-30 %,
    3-8x longer).
    """
    check_range("density", density, 0.01, 0.6)
    check_px(height, width, size=size)
    return redraw_until_open(lambda: _blocks_once(rng, height, width, density, size))


def _extra_block_side(rng: np.random.Generator, h: int, w: int) -> int:
    """Side of the blocks added to other families: 0.5-8 % of the longer side, clipped to 5-300 px."""
    return feature_px(rng, max(h, w), px=(5, 300), rel=(0.005, 0.08))


#: Wall thickness and gap width of :func:`gaps` (pixel range, range relative to the longer side, each).
_WALLS = ((3, 250), (0.005, 0.12), (6, 300), (0.015, 0.2))
#: The same for :func:`narrow_passage`: thick walls, narrow passages.
_NARROW_WALLS = ((10, 1000), (0.03, 0.22), (2, 16), (0.008, 0.03))


def _walls_with_gaps(rng: np.random.Generator, h: int, w: int, *, walls: int | None, thickness: int | None,
                     gap: int | None, narrow: bool) -> np.ndarray:
    """Vertical walls across all rows, each with 1-3 gaps (``narrow``: thick, ragged, narrow passages)."""
    L = max(h, w)
    wall_px, wall_rel, gap_px, gap_rel = _NARROW_WALLS if narrow else _WALLS
    t = max(1, min(feature_px(rng, L, px=wall_px, rel=wall_rel, given=thickness), w // 3))
    n = walls if walls is not None else int(rng.choice([1, 2, 3, 4], p=[0.4, 0.35, 0.18, 0.07])) + int(
        rng.integers(0, 1 + L // 400))
    n = max(1, min(n, int(0.6 * w / (t + 2))))
    out = np.zeros((h, w), dtype=bool)
    slot = w / n
    for i in range(n):
        lo = int(i * slot + 0.15 * slot - t / 2)
        hi = max(lo, int((i + 1) * slot - 0.15 * slot - t / 2))
        c = int(np.clip(rng.integers(lo, hi + 1), 0, w - t))
        c0, c1 = c, c + t
        if narrow:  # ragged outline: segments of varying thickness
            rects, r = [], 0
            while r < h:
                seg = max(2, int(rng.uniform(0.05, 0.25) * h))
                left, right = rng.uniform(-0.3, 0.3, 2) * t
                rects.append((r, c + int(left), r + seg, c + t + int(right)))
                r += seg
            out |= paint_rects((h, w), rects)
            c0, c1 = max(0, c - int(0.3 * t) - 1), min(w, c + t + int(0.3 * t) + 1)
        else:
            out[:, c0:c1] = True
        for _ in range(int(rng.choice([1, 2, 3], p=[0.5, 0.35, 0.15]))):
            g = max(1, min(feature_px(rng, L, px=gap_px, rel=gap_rel, given=gap), int(0.6 * h)))
            r = int(rng.integers(0, h - g + 1))
            if narrow and rng.random() < 0.4 and c1 - c0 > 3 * g:  # a dog-leg passage
                r2 = int(np.clip(r + rng.integers(-4 * g, 4 * g + 1), 0, h - g))
                mid = int(rng.integers(c0 + g, c1 - 2 * g + 1))
                out[r:r + g, c0:mid + g] = False
                out[min(r, r2):max(r, r2) + g, mid:mid + g] = False
                out[r2:r2 + g, mid:c1] = False
            else:
                out[r:r + g, c0:c1] = False
    return out


def _gaps_once(rng: np.random.Generator, h: int, w: int, walls: int | None, thickness: int | None,
               gap: int | None) -> np.ndarray:
    def draw(n: int | None, vertical: bool) -> np.ndarray:
        if vertical:
            return _walls_with_gaps(rng, h, w, walls=n, thickness=thickness, gap=gap, narrow=False)
        return _walls_with_gaps(rng, w, h, walls=n, thickness=thickness, gap=gap, narrow=False).T

    vertical = bool(rng.random() < 0.5)
    out = draw(walls, vertical)
    if walls is None and rng.random() < 0.2:  # one wall across the others
        out = out | draw(1, not vertical)
    return np.ascontiguousarray(out)


def gaps(rng: np.random.Generator, height: int, width: int, *, walls: int | None = None,
         thickness: int | None = None, gap: int | None = None) -> np.ndarray:
    """Straight walls right across the map, each with 1-3 gaps.

    Randomises the orientation, the number of ``walls`` (1-4, plus up to one more per 400 px of the
    longer side, at most as many as fit; on a fifth of the maps one wall across the others), the wall ``thickness`` (0.5-12 % of the
    longer side, clipped to 3-250 px) and each ``gap`` width (1.5-20 %, clipped to 6-300 px and to
    60 % of the wall) and position.
    """
    check_range("walls", walls, 1, 64, integer=True)
    check_px(height, width, thickness=thickness, gap=gap)
    return redraw_until_open(lambda: _gaps_once(rng, height, width, walls, thickness, gap))


def gaps_blocks(rng: np.random.Generator, height: int, width: int, *, density: float | None = None) -> np.ndarray:
    """Walls with gaps (as :func:`gaps`) plus random blocks (as :func:`blocks`).

    Randomises everything :func:`gaps` does, the blocks' obstacle fraction ``density`` (0.05-0.2)
    and their typical side (0.5-8 % of the longer side, clipped to 5-300 px).
    """
    check_range("density", density, 0.01, 0.5)

    def draw() -> np.ndarray:
        d = density if density is not None else rng.uniform(0.05, 0.2)
        side = _extra_block_side(rng, height, width)
        return _gaps_once(rng, height, width, None, None, None) | _blocks_once(rng, height, width, d, side)

    return redraw_until_open(draw)


def narrow_passage(rng: np.random.Generator, height: int, width: int, *, walls: int | None = None,
                   thickness: int | None = None, passage: int | None = None) -> np.ndarray:
    """Thick walls with ragged outlines right across the map, pierced by 1-3 narrow passages each.

    Randomises the orientation, the number of ``walls`` (as :func:`gaps`), their ``thickness``
    (3-22 % of the longer side, clipped to 10-1000 px, varying by +-30 % along the wall), each
    ``passage`` width (0.8-3 %, clipped to 2-16 px) and position, and dog-leg passages (40 %).
    """
    check_range("walls", walls, 1, 64, integer=True)
    check_px(height, width, thickness=thickness, passage=passage)
    return redraw_oriented(rng, height, width, lambda a, b: _walls_with_gaps(
        rng, a, b, walls=walls, thickness=thickness, gap=passage, narrow=True))


def _trap(rng: np.random.Generator, box: tuple[int, int, int, int], thickness: int) -> list:
    """Rectangles of a U (or, 40 %, C) shaped trap in ``box``, open to a random side."""
    t = max(1, min(thickness, (box[2] - box[0]) // 4, (box[3] - box[1]) // 4))
    lip = rng.uniform(0.15, 0.35) if rng.random() < 0.4 else 0.0
    return trap_rects(box, t, str(rng.choice(list("NSWE"))), lip)


def _trap_thickness(rng: np.random.Generator, h: int, w: int) -> int:
    return feature_px(rng, max(h, w), px=(2, 40), rel=(0.003, 0.04))


def bugtrap(rng: np.random.Generator, height: int, width: int, *, size: int | None = None,
            thickness: int | None = None) -> np.ndarray:
    """One U- or C-shaped bug trap around the start area (top half) or the goal area (bottom half).

    Randomises the trap ``size`` (20-55 % of the shorter side), its aspect (0.75-1.35), its wall
    ``thickness`` (0.3-4 % of the longer side, clipped to 2-40 px), the side it opens to, lips
    (a C shape, 40 %) and, on half the maps, extra blocks (obstacle fraction 3-12 %, side as in
    :func:`gaps_blocks`).
    """
    check_range("size", size, 8, max(height, width), integer=True)
    check_px(height, width, thickness=thickness)

    def draw() -> np.ndarray:
        s = size if size is not None else rng.uniform(0.2, 0.55) * min(height, width)
        box = trap_box(rng, height, width, s, str(rng.choice(["top", "bottom"])))
        t = thickness if thickness is not None else _trap_thickness(rng, height, width)
        out = paint_rects((height, width), _trap(rng, box, t))
        if rng.random() < 0.5:
            out |= _blocks_once(rng, height, width, rng.uniform(0.03, 0.12), _extra_block_side(rng, height, width))
        return out

    return redraw_until_open(draw)


def bugtraps(rng: np.random.Generator, height: int, width: int, *, count: int | None = None,
             thickness: int | None = None) -> np.ndarray:
    """Several (``count``) U- and C-shaped bug traps anywhere on the map, apart from each other.

    Randomises their number (2-6, plus one more per 300 px of the longer side), their sizes
    (log-uniform from 5 % of the shorter side, at least 24 px, to 40 %), the shared wall
    ``thickness`` (as :func:`bugtrap`), openings and lips, and on a third of the maps extra blocks
    (3-10 %).
    """
    check_range("count", count, 1, 256, integer=True)
    check_px(height, width, thickness=thickness)

    def draw() -> np.ndarray:
        n = count if count is not None else int(rng.integers(2, 7 + max(height, width) // 300))
        t = thickness if thickness is not None else _trap_thickness(rng, height, width)
        rects, boxes = [], np.empty((0, 4))
        for _ in range(n):
            for _ in range(30):  # traps do not overlap: place each one away from the others
                side = loguniform(rng, min(max(24.0, 0.05 * min(height, width)), 0.4 * min(height, width)),
                                  0.4 * min(height, width))
                box = trap_box(rng, height, width, side, "any")
                gap = 2 * t + 2
                if not ((boxes[:, 0] < box[2] + gap) & (box[0] < boxes[:, 2] + gap)
                        & (boxes[:, 1] < box[3] + gap) & (box[1] < boxes[:, 3] + gap)).any():
                    boxes = np.vstack([boxes, box])
                    rects += _trap(rng, box, t)
                    break
        out = paint_rects((height, width), rects)
        if rng.random() < 1 / 3:
            out |= _blocks_once(rng, height, width, rng.uniform(0.03, 0.1), _extra_block_side(rng, height, width))
        return out

    return redraw_until_open(draw)


def maze(rng: np.random.Generator, height: int, width: int, *, corridor: int | None = None,
         wall: int | None = None) -> np.ndarray:
    """A perfect maze (one route between any two cells) with straight corridors on a square lattice.

    Randomises the ``corridor`` width (2-25 px, log-uniform; at least ``L / 600 - 1`` px on a map
    whose longer side is ``L``, at most a third of the shorter side less one), the ``wall``
    thickness (1-8 px, at most 1.5 corridors), the horizontal/vertical bias of the passages (0.4-2.5) and the offset of
    the lattice; the pixels left over beside the lattice are wall. The tree is a random minimum
    spanning tree (randomised Kruskal) of the cell lattice.
    """
    check_px(height, width, corridor=corridor, wall=wall)
    L, S = max(height, width), min(height, width)

    def draw() -> np.ndarray:
        cw = corridor
        if cw is None:
            lo = max(2.0, L / 600 - 1)
            cw = int(round(loguniform(rng, lo, max(lo, min(25.0, S / 3 - 1)))))
        ww = wall if wall is not None else int(round(loguniform(rng, 1, max(1.0, min(8.0, 1.5 * cw)))))
        rows, cols = lattice_rows(height, width, cw, ww)
        grid = perfect_maze(rng, rows, cols, bias=loguniform(rng, 0.4, 2.5))
        return place_lattice(rng, grid, height, width, cw, ww)

    return redraw_until_open(draw)


def rooms(rng: np.random.Generator, height: int, width: int, *, room: int | None = None,
          wall: int | None = None, door: int | None = None) -> np.ndarray:
    """Rooms and corridors by recursive division inside an outer wall, a door in every wall.

    Randomises the smallest ``room`` side (3-30 % of the longer side, clipped to 20-900 px), the
    ``wall`` thickness (0.05-2 %, clipped to 1-8 px), the ``door`` width (0.6-7 %, clipped to
    4-80 px), the share of splits that are corridors (0-50 %; corridors 3-8 %, clipped to
    4-120 px) and how often mid-sized regions stay undivided (0-40 %). Every room is reachable.
    """
    check_range("room", room, 3, max(height, width), integer=True)
    check_px(height, width, wall=wall, door=door)
    L = max(height, width)

    def draw() -> np.ndarray:
        t = feature_px(rng, L, px=(1, 8), rel=(0.0005, 0.02), given=wall)
        rm = feature_px(rng, L, px=(20, 900), rel=(0.03, 0.3), given=room)
        d = feature_px(rng, L, px=(4, 80), rel=(0.006, 0.07), given=door)
        out = np.ones((height, width), dtype=bool)
        out[t:height - t, t:width - t] = False
        recursive_division(rng, out, (t, t, height - t, width - t), room=rm, wall=t, door=max(1, min(d, rm - 2)),
                           corridor=feature_px(rng, L, px=(4, 120), rel=(0.03, 0.08)),
                           corridor_p=rng.uniform(0.0, 0.5), stop_p=rng.uniform(0.0, 0.4))
        return out

    return redraw_until_open(draw)


def scatter(rng: np.random.Generator, height: int, width: int, *, density: float | None = None,
            size: int | None = None, squares: float | None = None) -> np.ndarray:
    """A random scatter of discs and squares, topped up until the obstacle fraction is ``density``.

    Randomises ``density`` (0.05-0.35), the largest diameter ``size`` (2-12 px times
    ``(L / 201) ** u``, ``u`` uniform in 0..1 and ``L`` the longer side, so large maps get both fine
    and coarse scatter; diameters are uniform in ``size / 4``..``size``) and the share of
    ``squares`` (none, all, or a random share).
    """
    check_range("density", density, 0.01, 0.6)
    check_px(height, width, size=size)
    check_range("squares", squares, 0.0, 1.0)
    L = max(height, width)

    def draw() -> np.ndarray:
        d = density if density is not None else rng.uniform(0.05, 0.35)
        s = size if size is not None else max(1, int(round(rng.uniform(2, 12) * (max(L, MODEL_SIDE) / MODEL_SIDE) ** rng.random())))
        q = squares if squares is not None else float(rng.choice([0.0, 1.0, rng.random()]))
        diameters = np.arange((s + 3) // 4, s + 1)
        mean_area = (1 - q) * np.mean([disc(int(k)).sum() for k in diameters]) + q * np.mean(diameters**2.0)
        first = int(0.7 * -np.log1p(-d) * height * width / mean_area) + 1
        return fill_to_density((height, width), d, lambda n: scatter_batch(rng, (height, width), n, s, q), first)

    return redraw_until_open(draw)


@dataclass(frozen=True)
class Family:
    """A named map family."""

    name: str
    """Registry name, e.g. ``"maze"``."""
    generate: Callable[..., np.ndarray]
    """``generate(rng, height, width, **params) -> obstacles`` (``bool``, ``True`` = obstacle)."""
    summary: str
    """One line: what the family draws."""


def _family(fn: Callable[..., np.ndarray]) -> Family:
    return Family(fn.__name__, fn, (fn.__doc__ or "").strip().splitlines()[0])


#: Every family by name (read-only by convention: build a new dict to add one).
FAMILIES: dict[str, Family] = {f.name: f for f in map(_family, (
    blocks, gaps, bugtrap, bugtraps, gaps_blocks, narrow_passage,
    maze, rooms, office, scatter, warehouse, ros_scan,
    city, cave, outdoor, corridor_maze, floor, dungeon,
))}

#: The families of maps people plan on at scale (city, caves, open ground, mazes of any corridor width,
#: large floors, dungeons; :mod:`ndrql.synth.cities`, :mod:`ndrql.synth.natural`). The shipped ``general``
#: model trained on the twelve before them.
LARGE_FAMILIES = ("city", "cave", "outdoor", "corridor_maze", "floor", "dungeon")


def shipped_families() -> tuple[str, ...]:
    """The twelve families the shipped ``general`` model trained on: every family but :data:`LARGE_FAMILIES`."""
    return tuple(name for name in FAMILIES if name not in LARGE_FAMILIES)


def family_names() -> tuple[str, ...]:
    """The registered family names, in registry order."""
    return tuple(FAMILIES)


def _params_of(fn: Callable[..., np.ndarray]) -> tuple[str, ...]:
    return tuple(p.name for p in inspect.signature(fn).parameters.values() if p.kind is p.KEYWORD_ONLY)


def generate_map(name: str, rng: np.random.Generator, height: int, width: int, **params: object) -> np.ndarray:
    """Draw one ``(height, width)`` map of family ``name`` from ``rng``; unknown names, parameters or sizes raise NdrqlError."""
    family = FAMILIES.get(name) if isinstance(name, str) else None
    if family is None:
        raise NdrqlError(f"unknown map family {name!r}; valid families: {', '.join(FAMILIES)}")
    if not isinstance(rng, np.random.Generator):
        raise NdrqlError(f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got {type(rng).__name__}")
    for side, value in (("height", height), ("width", width)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < MIN_SIDE:
            raise NdrqlError(f"map {side} must be an integer of at least {MIN_SIDE} px, got {value!r}")
    valid = _params_of(family.generate)
    unknown = sorted(set(params) - set(valid))
    if unknown:
        raise NdrqlError(f"family {name!r} has no parameter {', '.join(unknown)}; "
                         f"valid: {', '.join(valid) or 'none'}")
    return family.generate(rng, int(height), int(width), **params)
