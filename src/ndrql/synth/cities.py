"""Built map families at scale: city street grids, dungeons, large floors and mazes of any corridor width.

Look-alikes of the published descriptions of benchmark maps that people plan on at scale: city and
street maps (blocks of varied size between streets, avenues, parks, diagonal roads, a grid turned
as a whole), role-playing dungeons (rooms joined by long corridors), large office and warehouse
floors (zones of offices, racks and halls between main aisles) and mazes whose corridors range from
1 px to tens of pixels. Every random choice comes from the ``np.random.Generator`` passed in; every
map's free space is one area reaching opposite quadrants.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.sparse.csgraph import minimum_spanning_tree

from ndrql.synth.buildings import office, warehouse
from ndrql.synth.layouts import lattice_rows, perfect_maze, place_lattice
from ndrql.synth.shapes import (carve_segments, check_px, check_range, disc, feature_px, join_free_areas, loguniform,
                                paint_rects, redraw_until_open, smooth_noise, stamp)


def _spans(rng: np.random.Generator, extent: int, block: int, street: int) -> list[tuple[int, int]]:
    """Blocks ``(start, end)`` along one axis: block lengths ``block`` x 0.4-2.2, streets ``street`` wide
    (every 3rd-6th an avenue twice as wide), starting with a street at a random offset."""
    out, pos, every = [], int(rng.integers(0, street + 1)), int(rng.integers(3, 7))
    k = 0
    while pos < extent:
        length = max(2, int(block * loguniform(rng, 0.4, 2.2)))
        out.append((pos, min(extent, pos + length)))
        k += 1
        pos += length + street * (2 if k % every == 0 else 1)
    return out


def _block_buildings(rng: np.random.Generator, box: tuple[int, int, int, int], alley: int) -> list:
    """Buildings of one city block ``(r0, c0, r1, c1)``: a 1-4 x 1-4 grid of lots split by alleys, some lots
    empty (yards, parking), each building set back 0-2 px from its lot."""
    r0, c0, r1, c1 = box
    nr = int(rng.integers(1, 1 + max(1, min(4, (r1 - r0) // max(3, 2 * alley + 3)))))
    nc = int(rng.integers(1, 1 + max(1, min(4, (c1 - c0) // max(3, 2 * alley + 3)))))
    rows = np.linspace(r0, r1, nr + 1).astype(int)
    cols = np.linspace(c0, c1, nc + 1).astype(int)
    empty = rng.uniform(0.0, 0.25)
    rects = []
    for i in range(nr):
        for j in range(nc):
            if rng.random() < empty:
                continue
            back = int(rng.integers(0, 3)) if min(r1 - r0, c1 - c0) > 12 else 0
            a = alley // 2 if nr > 1 or nc > 1 else 0
            rects.append((rows[i] + back + (a if i else 0), cols[j] + back + (a if j else 0),
                          rows[i + 1] - back - (a if i < nr - 1 else 0), cols[j + 1] - back - (a if j < nc - 1 else 0)))
    return rects


def _city_once(rng: np.random.Generator, h: int, w: int, block: int | None, street: int | None) -> np.ndarray:
    L = max(h, w)
    b = feature_px(rng, L, px=(6, 320), rel=(0.02, 0.16), given=block)
    s = feature_px(rng, L, px=(2, 48), rel=(0.004, 0.03), given=street)
    turn = rng.uniform(5, 40) * rng.choice([-1, 1]) if rng.random() < 0.3 else 0.0
    side = int(np.ceil(np.hypot(h, w))) + 2 if turn else max(h, w)
    H, W = (side, side) if turn else (h, w)
    alley = max(1, int(s * rng.uniform(0.2, 0.6)))
    park = rng.uniform(0.0, 0.15)
    rects = []
    for br in _spans(rng, H, b, s):
        for bc in _spans(rng, W, int(b * loguniform(rng, 0.6, 1.7)), s):
            if rng.random() >= park:
                rects += _block_buildings(rng, (br[0], bc[0], br[1], bc[1]), alley)
    out = paint_rects((H, W), rects)
    for _ in range(int(rng.choice([0, 1, 2], p=[0.5, 0.35, 0.15]))):  # diagonal avenues cut through the blocks
        p = rng.uniform(0, 1, 2) * (H, W)
        angle = rng.uniform(0, np.pi)
        d = np.array([np.sin(angle), np.cos(angle)]) * 2 * max(H, W)
        out &= ~carve_segments((H, W), [(p - d, p + d)], max(2, int(s * 1.5)))
    if turn:
        out = ndimage.rotate(out.astype(np.uint8), turn, reshape=False, order=0, mode="constant", cval=0).astype(bool)
        r0, c0 = (H - h) // 2, (W - w) // 2
        out = out[r0:r0 + h, c0:c0 + w]
    if rng.random() < 0.3:  # water or the edge of town: a large irregular blocked area
        water = smooth_noise(rng, (h, w), max(4, L // 3))
        out |= water <= np.quantile(water, rng.uniform(0.05, 0.25))
    return join_free_areas(out, max(1, s), min_area=max(4, s * s))


def city(rng: np.random.Generator, height: int, width: int, *, block: int | None = None,
         street: int | None = None) -> np.ndarray:
    """A city street grid: blocks of varied size between streets and avenues, parks, diagonal roads.

    Randomises the typical ``block`` length (2-16 % of the longer side, clipped to 6-320 px; each
    block 0.4-2.2x that, rows and columns of blocks with their own typical length), the ``street``
    width (0.4-3 %, clipped to 2-48 px; every 3rd-6th an avenue twice as wide), the buildings of each
    block (a 1-4 x 1-4 grid of lots split by alleys 0.2-0.6 streets wide, 0-25 % of lots empty, set
    back 0-2 px), parks (0-15 % of blocks), 0-2 diagonal avenues, the whole grid turned by 5-40
    degrees (30 % of maps) and water or open country blocking 5-25 % of the map (30 %). Courtyards
    that no street reaches are filled.
    """
    check_px(height, width, block=block, street=street)
    return redraw_until_open(lambda: _city_once(rng, height, width, block, street))


def _rooms_of_dungeon(rng: np.random.Generator, h: int, w: int, room: int, count: int) -> np.ndarray:
    """Up to ``count`` non-overlapping rooms ``(r0, c0, r1, c1)``, sides ``room`` x 0.5-2, apart by a room/3."""
    boxes = np.empty((0, 4), np.int64)
    gap = max(2, room // 3)
    for _ in range(count * 8):
        if len(boxes) >= count:
            break
        rh, rw = (max(3, min(int(room * loguniform(rng, 0.5, 2.0)), n - 2)) for n in (h, w))
        r0, c0 = int(rng.integers(1, max(2, h - rh))), int(rng.integers(1, max(2, w - rw)))
        box = np.array([r0, c0, r0 + rh, c0 + rw])
        if not ((boxes[:, 0] < box[2] + gap) & (box[0] < boxes[:, 2] + gap)
                & (boxes[:, 1] < box[3] + gap) & (box[1] < boxes[:, 3] + gap)).any():
            boxes = np.vstack([boxes, box])
    return boxes


def _dungeon_once(rng: np.random.Generator, h: int, w: int, room: int | None, corridor: int | None) -> np.ndarray:
    L = max(h, w)
    rm = feature_px(rng, L, px=(6, 240), rel=(0.03, 0.15), given=room)
    fill = rng.uniform(0.08, 0.3)
    boxes = _rooms_of_dungeon(rng, h, w, rm, int(np.clip(fill * h * w / rm**2, 3, 300)))
    cw = corridor if corridor is not None else max(1, int(round(loguniform(rng, 1, max(1.0, rm / 3)))))
    free = np.zeros((h, w), bool)
    for r0, c0, r1, c1 in boxes:
        if rng.random() < 0.2 and min(r1 - r0, c1 - c0) >= 6:  # a round chamber
            d = int(min(r1 - r0, c1 - c0))
            stamp(free, np.array([r0]), np.array([c0]), disc(d))
        else:
            free[r0:r1, c0:c1] = True
    centres = np.stack([(boxes[:, 0] + boxes[:, 2]) // 2, (boxes[:, 1] + boxes[:, 3]) // 2], axis=1)
    dist = np.hypot(*(centres[:, None, :] - centres[None, :, :]).transpose(2, 0, 1)) + 1e-3
    tree = minimum_spanning_tree(np.triu(dist, 1)).tocoo()
    edges = list(zip(tree.row.tolist(), tree.col.tolist()))
    extra = rng.uniform(0.0, 0.2)  # loops: some more pairs of near rooms
    for i in range(len(centres)):
        j = int(np.argsort(dist[i])[min(2, len(centres) - 1)])
        if j != i and rng.random() < extra:
            edges.append((i, j))
    segments = []
    for i, j in edges:  # L-shaped corridors, turning at one end or the other
        p, q = centres[i], centres[j]
        corner = (p[0], q[1]) if rng.random() < 0.5 else (q[0], p[1])
        segments += [(p, corner), (corner, q)]
    free |= carve_segments((h, w), segments, cw)
    out = ~free
    if rng.random() < 0.3:  # pillars in the large rooms
        pil = paint_rects((h, w), [(r, c, r + 2, c + 2) for r0, c0, r1, c1 in boxes if min(r1 - r0, c1 - c0) > 16
                                   for r in range(r0 + 4, r1 - 5, 6) for c in range(c0 + 4, c1 - 5, 6)])
        out |= pil
    return join_free_areas(out, cw, min_area=1)


def dungeon(rng: np.random.Generator, height: int, width: int, *, room: int | None = None,
            corridor: int | None = None) -> np.ndarray:
    """Rooms in solid rock joined by long corridors: a role-playing dungeon.

    Randomises the typical ``room`` side (3-15 % of the longer side, clipped to 6-240 px; each side
    0.5-2x that), how much of the map the rooms fill (8-30 %, at most 300 rooms, a room/3 apart),
    round chambers (20 % of rooms), the ``corridor`` width (1 px to a third of a room, log-uniform),
    the corridors (a minimum spanning tree of the room centres plus 0-20 % extra loops, each corridor
    L-shaped) and pillars in large rooms (30 % of maps).
    """
    check_px(height, width, room=room, corridor=corridor)
    return redraw_until_open(lambda: _dungeon_once(rng, height, width, room, corridor))


def _zone(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    """One zone of a large floor: offices, racks, an open hall with columns, or an empty hall."""
    kind = rng.choice(["office", "warehouse", "hall", "open"], p=[0.4, 0.35, 0.15, 0.1])
    if kind == "office" and min(h, w) >= 24:
        return office(rng, h, w)
    if kind == "warehouse" and min(h, w) >= 24:
        return warehouse(rng, h, w)
    out = np.zeros((h, w), bool)
    if kind != "open":
        pitch = max(4, int(rng.uniform(0.1, 0.3) * min(h, w)))
        col = max(1, pitch // 6)
        out |= paint_rects((h, w), [(r, c, r + col, c + col) for r in range(pitch // 2, h - col, pitch)
                                    for c in range(pitch // 2, w - col, pitch)])
    return out


def _floor_once(rng: np.random.Generator, h: int, w: int, zone: int | None, aisle: int | None) -> np.ndarray:
    L = max(h, w)
    z = feature_px(rng, L, px=(32, 600), rel=(0.15, 0.5), given=zone)
    a = feature_px(rng, L, px=(3, 60), rel=(0.008, 0.04), given=aisle)
    wall = max(1, int(loguniform(rng, 1, max(1.0, a / 3))))
    out = np.ones((h, w), bool)
    out[wall:h - wall, wall:w - wall] = False
    for r0, r1 in _spans(rng, h - 2 * wall, z, a):
        for c0, c1 in _spans(rng, w - 2 * wall, int(z * loguniform(rng, 0.6, 1.7)), a):
            zh, zw = r1 - r0, c1 - c0
            if zh >= 4 and zw >= 4:
                out[wall + r0:wall + r1, wall + c0:wall + c1] = _zone(rng, zh, zw)
    return join_free_areas(out, max(2, a // 2), min_area=max(4, a * a))


def floor(rng: np.random.Generator, height: int, width: int, *, zone: int | None = None,
          aisle: int | None = None) -> np.ndarray:
    """A large office or warehouse floor: zones of offices, racks and halls between main aisles.

    Randomises the typical ``zone`` side (15-50 % of the longer side, clipped to 32-600 px; zones
    0.4-2.2x that), the main ``aisle`` width (0.8-4 %, clipped to 3-60 px; every 3rd-6th twice as
    wide), the outer wall (1 px to a third of an aisle) and each zone: an office plan (40 %, as
    ``office``), racks (35 %, as ``warehouse``), a hall with a lattice of columns (15 %) or an empty
    hall. Zones that no aisle reaches get a doorway half an aisle wide; pockets are filled.
    """
    check_px(height, width, zone=zone, aisle=aisle)
    return redraw_until_open(lambda: _floor_once(rng, height, width, zone, aisle))


def corridor_maze(rng: np.random.Generator, height: int, width: int, *, corridor: int | None = None,
                  wall: int | None = None, loops: float | None = None) -> np.ndarray:
    """A maze with corridors from 1 px to tens of pixels wide, as benchmark maze sets vary them.

    Randomises the ``corridor`` width (log-uniform 1-64 px, at most an eighth of the shorter side),
    the ``wall`` thickness (equal to the corridor on half the maps, else log-uniform from 1 px to the
    corridor), the share of inner walls removed to make ``loops`` (none on half the maps, else up to
    15 %) and the offset of the lattice; the pixels left beside the lattice are wall.
    """
    check_px(height, width, corridor=corridor, wall=wall)
    check_range("loops", loops, 0.0, 1.0)
    S = min(height, width)

    def draw() -> np.ndarray:
        cw = corridor if corridor is not None else int(round(loguniform(rng, 1, max(1.0, min(64.0, S / 8)))))
        ww = wall if wall is not None else (cw if rng.random() < 0.5 else int(round(loguniform(rng, 1, cw))))
        rows, cols = lattice_rows(height, width, cw, ww)
        grid = perfect_maze(rng, rows, cols, bias=loguniform(rng, 0.5, 2.0))
        share = loops if loops is not None else (0.0 if rng.random() < 0.5 else rng.uniform(0.0, 0.15))
        inner = np.zeros_like(grid)
        inner[1:-1:2, 2:-1:2] = True  # walls between horizontal neighbours
        inner[2:-1:2, 1:-1:2] = True  # walls between vertical neighbours
        grid &= ~(inner & (rng.random(grid.shape) < share))
        return place_lattice(rng, grid, height, width, cw, ww)

    return redraw_until_open(draw)
