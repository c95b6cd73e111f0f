"""Building-like map families: office floor plans, warehouses and ROS-style building scans.

Same contract as every family in :mod:`ndrql.synth.families` (which registers these):
``generate(rng, height, width, **params) -> obstacles``, ``bool``, ``True`` = obstacle, every
random choice from ``rng``, parameters left at ``None`` randomised, sizes drawn in pixels and
relative to the map, and the result redrawn until its free space is open
(:func:`ndrql.synth.shapes.is_open`).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ndrql.synth.layouts import rect_union_footprint, recursive_division
from ndrql.synth.shapes import (check_px, check_range, feature_px, paint_rects, redraw_oriented, redraw_until_open,
                                smooth_noise)

Rect = tuple[int, int, int, int]


def _furniture(rng: np.random.Generator, room: Rect, count: int, largest: int) -> list[Rect]:
    """``count`` desks and cabinets in ``room = (r0, c0, r1, c1)``, most against a wall, sides at most ``largest``."""
    r0, c0, r1, c1 = room
    hh, ww = r1 - r0, c1 - c0
    out = []
    for _ in range(count):
        fh = max(1, int(min(rng.uniform(0.1, 0.35) * hh, rng.uniform(0.3, 1.0) * largest)))
        fw = max(1, int(min(rng.uniform(0.1, 0.35) * ww, rng.uniform(0.3, 1.0) * largest)))
        r = r0 + int(rng.integers(0, max(1, hh - fh + 1)))
        c = c0 + int(rng.integers(0, max(1, ww - fw + 1)))
        side = rng.integers(0, 6)  # 0-3: pushed against that wall; 4-5: free-standing
        if side == 0:
            r = r0
        elif side == 1:
            r = r1 - fh
        elif side == 2:
            c = c0
        elif side == 3:
            c = c1 - fw
        out.append((r, c, r + fh, c + fw))
    return out


def _room_columns(rng: np.random.Generator, c0: int, c1: int, width: int) -> list[tuple[int, int]]:
    """Split the columns ``[c0, c1)`` into rooms about ``width`` wide (0.6-1.5x), leaving one wall column between."""
    rooms, c = [], c0
    while c < c1:
        rw = max(3, int(width * rng.uniform(0.6, 1.5)))
        if c1 - (c + rw) < 0.5 * width:
            rw = c1 - c
        rooms.append((c, c + rw))
        c += rw
    return rooms


def _office_bands(rng: np.random.Generator, inner: int, t: int, cw: int, depth: int,
                  min_depth: int) -> tuple[int, list[int]]:
    """Number of corridors and the depth of each band of rooms between them (outer bands one room deep, inner two)."""
    cw = max(2, min(cw, inner - 2 * min_depth - 2 * t))
    n = max(1, int(round((inner + t) / (cw + 3 * t + 2 * depth))))
    while n > 1 and inner - n * (cw + 2 * t) < (n + 1) * 2 * min_depth:
        n -= 1
    spare = max(0, inner - n * (cw + 2 * t))
    weight = np.array([1.0] + [2.0] * (n - 1) + [1.0]) * rng.uniform(0.8, 1.2, n + 1)
    depths = np.floor(spare * weight / weight.sum()).astype(int)
    depths[-1] = spare - depths[:-1].sum()
    return cw, [int(d) for d in depths]


def _office_plan(rng: np.random.Generator, h: int, w: int, wall: int | None, corridor: int | None,
                 furniture: int | None) -> np.ndarray:
    """An office with corridors along the rows (canonical orientation); see :func:`office`."""
    L = max(h, w)
    t = feature_px(rng, L, px=(1, 10), rel=(0.0005, 0.02), given=wall)
    cw = feature_px(rng, L, px=(5, 120), rel=(0.015, 0.09), given=corridor)
    room_w = feature_px(rng, L, px=(20, 400), rel=(0.025, 0.2))
    door = max(1, min(feature_px(rng, L, px=(4, 60), rel=(0.008, 0.05)), int(0.4 * room_w)))
    n_furn = furniture if furniture is not None else int(rng.integers(0, 5))
    t = max(1, min(t, h // 12, w // 12))
    out = np.zeros((h, w), dtype=bool)
    out[:t], out[h - t:], out[:, :t], out[:, w - t:] = True, True, True, True
    min_depth = max(3, door + 2)
    cw, depths = _office_bands(rng, h - 2 * t, t, cw, max(min_depth, int(room_w * rng.uniform(0.7, 1.6))), min_depth)
    walls, furn, clear, r = [], [], [], t
    for b, depth in enumerate(depths):
        r0, r1 = r, r + depth
        r = r1 + 2 * t + cw
        if b < len(depths) - 1:  # the corridor below this band, between two walls
            walls += [(r1, t, r1 + t, w - t), (r1 + t + cw, t, r1 + 2 * t + cw, w - t)]
        up, down = b > 0, b < len(depths) - 1
        cols = _room_columns(rng, t, w - t, room_w)
        if up and down:  # an inner band: a hall through it joins the corridors; rooms back to back
            k = int(rng.integers(len(cols)))
            clear.append((r0 - t, cols[k][0] + (t if k else 0), r1 + t, cols[k][1]))
            if depth >= 2 * min_depth + t:
                p = r0 + (depth - t) // 2
                walls.append((p, t, p + t, w - t))
                rows = [(r0, p, "up"), (p + t, r1, "down")]
            else:
                rows = [(r0, r1, str(rng.choice(["up", "down"])))]
        else:
            rows = [(r0, r1, "up" if up else "down")]
        for a0, a1, side in rows:
            _office_row(rng, (a0, a1), cols, side, t, door, min_depth, room_w, n_furn, walls, furn, clear)
    out |= paint_rects((h, w), walls + furn)
    for r0, c0, r1, c1 in clear:
        out[r0:r1, c0:c1] = False
    return out


def _office_row(rng: np.random.Generator, rows: tuple[int, int], cols: list[tuple[int, int]], side: str, t: int,
                door: int, min_depth: int, room_w: int, n_furn: int, walls: list, furn: list, clear: list) -> None:
    """One row of rooms with doors onto the corridor on ``side``; appends walls, furniture and clear zones."""
    r0, r1 = rows
    if len(cols) > 2 and rng.random() < 0.25:  # an open-plan area: merge a run of rooms
        i = int(rng.integers(0, len(cols) - 1))
        j = int(rng.integers(i + 2, len(cols) + 1))
        cols = cols[:i] + [(cols[i][0], cols[j - 1][1])] + cols[j:]
    for k, (c0, c1) in enumerate(cols):
        if k > 0:
            walls.append((r0, c0, r1, c0 + t))
            c0 += t
        for _ in range(1 if c1 - c0 < 3 * room_w else 2):
            d = min(door, c1 - c0)
            dc = c0 + int(rng.integers(0, c1 - c0 - d + 1))
            reach = min(r1 - r0, 2 * d + 2)
            clear.append((r0 - t, dc, r0 + reach, dc + d) if side == "up" else (r1 - reach, dc, r1 + t, dc + d))
        rooms = [(r0, c0, r1, c1)]
        if r1 - r0 >= max(2 * min_depth + t, int(1.2 * room_w)) and rng.random() < 0.35:  # a back room
            p = int(rng.integers(r0 + min_depth, r1 - min_depth - t + 1))
            walls.append((p, c0, p + t, c1))
            d = min(door, c1 - c0)
            dc = c0 + int(rng.integers(0, c1 - c0 - d + 1))
            clear.append((p - min_depth // 2, dc, p + t + min_depth // 2, dc + d))
            rooms = [(r0, c0, p, c1), (p + t, c0, r1, c1)]
        for room in rooms:
            area = (room[2] - room[0]) * (room[3] - room[1]) / max(1, room_w * min_depth)
            count = int(round(n_furn * rng.uniform(0.3, 1.0) * np.clip(area, 0.5, 4.0)))
            furn += _furniture(rng, room, count, max(2, int(0.4 * room_w)))


def office(rng: np.random.Generator, height: int, width: int, *, wall: int | None = None,
           corridor: int | None = None, furniture: int | None = None) -> np.ndarray:
    """An office floor plan: long parallel corridors, rows of rooms off them with doors, furniture.

    Rows of rooms one deep line the outer walls; between two corridors the rooms stand back to back,
    and a hall through that band joins the corridors (one corridor on small maps, more where they
    fit). Randomises the orientation, the ``wall`` thickness (0.05-2 % of the longer side, clipped to
    1-10 px), the ``corridor`` width (1.5-9 %, clipped to 5-120 px), room widths (2.5-20 %,
    clipped to 20-400 px, each 0.6-1.5x) and depths (0.7-1.6 widths), door widths (0.8-5 %,
    clipped to 4-60 px, at most 0.4 room widths), back rooms (35 % of deep rooms), open-plan areas
    (a quarter of the rows) and up to about ``furniture`` (0-4) desks and cabinets per room-sized
    area. Doorways are kept clear.
    """
    check_px(height, width, wall=wall, corridor=corridor)
    check_range("furniture", furniture, 0, 64, integer=True)
    return redraw_oriented(rng, height, width, lambda h, w: _office_plan(rng, h, w, wall, corridor, furniture))


def _warehouse_plan(rng: np.random.Generator, h: int, w: int, aisle: int | None, shelf: int | None,
                    cross: int | None) -> np.ndarray:
    """A warehouse with shelving along the rows (canonical orientation); see :func:`warehouse`."""
    L = max(h, w)
    a = feature_px(rng, L, px=(4, 80), rel=(0.008, 0.07), given=aisle)
    s = feature_px(rng, L, px=(2, 40), rel=(0.003, 0.03), given=shelf)
    depth = 2 * s if rng.random() < 0.6 else s
    a, depth = max(2, min(a, min(h, w) // 5)), max(1, min(depth, min(h, w) // 5))
    t = feature_px(rng, L, px=(1, 8), rel=(0.0005, 0.01)) if rng.random() < 0.7 else 0
    m = max(2, min(int(a * rng.uniform(1.0, 2.0)), (min(h, w) - 2 * t) // 6))
    out = np.zeros((h, w), dtype=bool)
    if t:
        out[:t], out[h - t:], out[:, :t], out[:, w - t:] = True, True, True, True
    ar0, ar1, ac0, ac1 = t + m, h - t - m, t + m, w - t - m
    n_cross = cross if cross is not None else int(rng.integers(0, 4))
    n_cross = max(0, min(n_cross, (ac1 - ac0) // (4 * a) - 1))
    cut = np.sort(rng.uniform(0.15, 0.85, n_cross)) if n_cross else np.empty(0)
    segs, c = [], ac0
    for x in cut:
        cx, cwid = ac0 + int(x * (ac1 - ac0)), max(a, int(a * rng.uniform(1.0, 1.8)))
        if cx - c >= 2 * a:
            segs.append((c, cx))
            c = cx + cwid
    segs.append((c, ac1))
    rects, rows, r = [], [], ar0
    while r + depth <= ar1:
        rows.append(r)
        rects += [(r, c0, r + depth, c1) for c0, c1 in segs if c1 > c0]
        r += depth + a
    p_block = rng.uniform(0.0, 0.4)
    for top in rows[:-1]:  # the aisle below each rack row but the last
        if rng.random() < p_block:
            c0 = ac0 if rng.random() < 0.5 else ac1 - max(s, 2)
            rects.append((top + depth, c0, top + depth + a, c0 + max(s, 2)))
    if rng.random() < 0.5:  # pallets in the main aisle around the racks
        for _ in range(int(rng.integers(1, 7))):
            p = max(1, int(a * rng.uniform(0.3, 0.7)))
            side = rng.integers(4)
            rr = int(rng.integers(t, max(t + 1, h - t - p)))
            cc = int(rng.integers(t, max(t + 1, w - t - p)))
            rr = t if side == 0 else (h - t - p if side == 1 else rr)
            cc = t if side == 2 else (w - t - p if side == 3 else cc)
            rects.append((rr, cc, rr + p, cc + p))
    return out | paint_rects((h, w), rects)


def warehouse(rng: np.random.Generator, height: int, width: int, *, aisle: int | None = None,
              shelf: int | None = None, cross: int | None = None) -> np.ndarray:
    """Warehouse shelving: long rack rows with aisles, cross aisles, some aisle ends blocked, pallets.

    Randomises the orientation, the ``aisle`` width (0.8-7 % of the longer side, clipped to
    4-80 px), the ``shelf`` depth (0.3-3 %, clipped to 2-40 px; back-to-back double racks on 60 %
    of the maps), the number of ``cross`` aisles (0-3, 1-1.8 aisles wide), the main aisle around
    the racks (1-2 aisles), an outer wall (70 %), the share of aisles blocked at one end (0-40 %)
    and pallets in the main aisle (half the maps).
    """
    check_px(height, width, aisle=aisle, shelf=shelf)
    check_range("cross", cross, 0, 64, integer=True)
    return redraw_oriented(rng, height, width, lambda h, w: _warehouse_plan(rng, h, w, aisle, shelf, cross))


def _ros_once(rng: np.random.Generator, h: int, w: int, outside: float | None, wall: int | None,
              noise: float | None) -> np.ndarray:
    L = max(h, w)
    frac = outside if outside is not None else rng.uniform(0.3, 0.6)
    t = feature_px(rng, L, px=(1, 6), rel=(0.0005, 0.012), given=wall)
    rotate = rng.random() < 0.35 and max(h, w) <= 1.3 * min(h, w)  # a turned building, on squarish maps
    t = max(t, 2) if rotate else t
    m = int(min(h, w) * rng.uniform(0.0, 0.06))  # unknown margin all round
    ih, iw = h - 2 * m, w - 2 * m
    foot = np.zeros((h, w), dtype=bool)
    foot[m:h - m, m:w - m] = rect_union_footprint(rng, (ih, iw), min(0.97, (1.0 - frac) * h * w / (ih * iw)))
    inner = ndimage.minimum_filter(foot, size=2 * t + 1, mode="constant", cval=False)
    rows, cols = np.nonzero(foot.any(axis=1))[0], np.nonzero(foot.any(axis=0))[0]
    div = np.zeros((h, w), dtype=bool)
    room = feature_px(rng, L, px=(16, 600), rel=(0.03, 0.22))
    recursive_division(rng, div, (int(rows[0]), int(cols[0]), int(rows[-1]) + 1, int(cols[-1]) + 1), room=room,
                       wall=t, door=max(2, min(room // 2, feature_px(rng, L, px=(4, 60), rel=(0.008, 0.05)))),
                       corridor=feature_px(rng, L, px=(4, 100), rel=(0.03, 0.07)),
                       corridor_p=rng.uniform(0.1, 0.5), stop_p=rng.uniform(0.1, 0.5))
    out = ~inner | div
    # Clutter: small pieces of furniture and scan returns.
    n = int(rng.uniform(0.0, 1.5) * foot.sum() / max(1, room) ** 2 * 6)
    size = max(2, int(room * 0.15))
    fr, fc = rng.integers(0, h, n), rng.integers(0, w, n)
    fh, fw = rng.integers(1, size + 1, n), rng.integers(1, size + 1, n)
    out |= paint_rects((h, w), np.stack([fr, fc, fr + fh, fc + fw], axis=1)) & inner
    # Seen through windows: ragged free patches just outside the outline, the wall broken beside them.
    reach = max(2, int(L * rng.uniform(0.005, 0.04)))
    near = ndimage.maximum_filter(foot, size=2 * reach + 1) & ~foot
    spill = near & (smooth_noise(rng, (h, w), max(2, L // 30)) > rng.uniform(0.55, 0.7))
    spill &= rng.random((h, w)) < 0.85
    out &= ~(spill | (ndimage.maximum_filter(spill, size=2 * t + 3) & foot & ~inner))
    p = noise if noise is not None else (rng.uniform(0.0005, 0.004) if rng.random() < 0.7 else 0.0)
    if p > 0:
        out |= (rng.random((h, w)) < p) & inner
    if rotate:
        angle = rng.uniform(-30.0, 30.0)
        out = ndimage.rotate(out.view(np.uint8), angle, order=0, reshape=False, cval=1, prefilter=False) > 0
    return out


def ros_scan(rng: np.random.Generator, height: int, width: int, *, outside: float | None = None,
             wall: int | None = None, noise: float | None = None) -> np.ndarray:
    """A building interior as a ROS ``map_server`` scan shows it: unknown (blocked) outside, thin walls.

    The outline is a union of rectangles (wings) around the map centre, inside an unknown margin
    of 0-6 % of the shorter side. Randomises the blocked ``outside`` (30-60 % of the map), the
    ``wall`` thickness (0.05-1.2 % of the longer side, clipped to 1-6 px), rooms and corridors by
    recursive division (room sides 3-22 %, clipped to 16-600 px), clutter, ragged free patches
    seen through windows just outside the outline, single-pixel ``noise`` specks (on 70 % of the
    maps, 0.05-0.4 % of the free pixels) and, on a third of the squarish maps, a turn of the whole
    scan by up to 30 degrees.
    """
    check_range("outside", outside, 0.0, 0.85)
    check_px(height, width, wall=wall)
    check_range("noise", noise, 0.0, 0.2)
    return redraw_until_open(lambda: _ros_once(rng, height, width, outside, wall, noise))
