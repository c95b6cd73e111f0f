"""A route drawn as the dataset draws its labels, per planning cell: the exact source's region and guideline.

:func:`route_cells` takes a polyline in pixels (the waypoints of a near-shortest path on an image of ``px`` pixels
per cell), stamps a ``guide_px`` square at samples a quarter pixel apart along it (the guideline), widens it by a
square window (the region: every pixel with a guideline pixel from ``region_px // 2`` before it to
``region_px - 1 - region_px // 2`` after it in both axes, ``cv2.dilate``'s rule) and returns each cell's share of
region and guideline pixels. The C extension's ``route_cells`` does it inside the guideline's bounding box in one
pass; :func:`route_cells_numpy`, the reference and the fallback when the extension is not built, draws the whole
image with numpy. Both give the same bits (tests/maps/test_route_cells.py); which runs is
:mod:`ndrql.maps.native`'s choice.
"""

from __future__ import annotations

import numpy as np

from ndrql.maps.native import c_kernels

#: Distance between two samples along a segment, in pixels.
SAMPLE_PX = 0.25


def sample_counts(waypoints: np.ndarray) -> np.ndarray:
    """Samples per segment of the polyline (both ends included): ``ceil(length / SAMPLE_PX) + 1``, int64."""
    d = np.diff(np.asarray(waypoints, np.float64).reshape(-1, 2), axis=0)
    return (np.ceil(np.hypot(d[:, 0], d[:, 1]) / SAMPLE_PX) + 1).astype(np.int64)


def window_any(img: np.ndarray, before: int, after: int, axis: int) -> np.ndarray:
    """Pixel set where ``img`` has a set pixel from ``before`` before it to ``after`` after it along ``axis``
    (zero outside): ``before`` zeros in front, then in-place ORs of the array with itself shifted by 1, 2, 4, ...
    (a window of ``w`` pixels in about log2(w) passes over contiguous memory)."""
    a = np.asarray(img, dtype=bool)
    n = a.shape[axis]
    pad = [(0, 0), (0, 0)]
    pad[axis] = (before, 0)
    f = np.pad(a, pad)
    width, span = before + after + 1, 1

    def cut(lo: int, hi: int | None) -> tuple[slice, ...]:
        return (slice(lo, hi), slice(None)) if axis == 0 else (slice(None), slice(lo, hi))

    while span < width:  # f[i] = any(a_padded[i : i + span])
        step = min(span, width - span)
        f[cut(0, -step)] |= f[cut(step, None)]
        span += step
    return f[cut(0, n)]


def cell_means(img: np.ndarray, px: int) -> np.ndarray:
    """Mean of each ``px`` x ``px`` block of a boolean image whose sides are multiples of ``px`` (sums of strided
    slices: numpy sums a short last axis slowly)."""
    a = np.asarray(img, dtype=np.uint8)
    cols = sum(a[:, k::px] for k in range(px))
    return sum(cols[k::px].astype(np.uint16) for k in range(px)) / float(px * px)


def route_cells_numpy(waypoints: np.ndarray, shape: tuple[int, int], px: int, guide_px: int,
                      region_px: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`route_cells` drawn on the whole image with numpy (the reference)."""
    waypoints = np.asarray(waypoints, np.float64).reshape(-1, 2)
    h, w = shape[0] * px, shape[1] * px
    pts = [waypoints[:1]]
    for a, b in zip(waypoints[:-1], waypoints[1:]):
        n = int(np.ceil(np.hypot(*(b - a)) / SAMPLE_PX)) + 1
        pts.append(a + (b - a) * np.linspace(0.0, 1.0, n)[:, None])
    p = np.concatenate(pts)
    guide = np.zeros((h, w), dtype=bool)
    top = np.floor(p - (guide_px - 1) / 2).astype(np.int64)  # a guide_px square per sample
    for dr in range(guide_px):
        for dc in range(guide_px):
            r, c = np.clip(top[:, 0] + dr, 0, h - 1), np.clip(top[:, 1] + dc, 0, w - 1)
            guide[r, c] = True
    before, after = region_px // 2, region_px - 1 - region_px // 2
    region = window_any(window_any(guide, before, after, 0), before, after, 1)
    return cell_means(region, px), cell_means(guide, px)


def route_cells(waypoints: np.ndarray, shape: tuple[int, int], px: int, guide_px: int,
                region_px: int) -> tuple[np.ndarray, np.ndarray]:
    """``(region, guideline)``: per cell of a ``shape`` grid, the share of its ``px`` x ``px`` pixels that the
    region and the guideline of the polyline ``waypoints`` (``(K, 2)`` pixel coordinates, row and column) cover
    (module docstring), float64. The C kernel when built, else :func:`route_cells_numpy`; the same bits."""
    kernel = getattr(c_kernels(), "route_cells", None)  # None: no extension, or one built before this kernel
    if kernel is None:
        return route_cells_numpy(waypoints, shape, px, guide_px, region_px)
    wp = np.ascontiguousarray(waypoints, np.float64).reshape(-1, 2)
    rows, cols = int(shape[0]), int(shape[1])
    region, guide = kernel(wp, sample_counts(wp), rows, cols, int(px), int(guide_px), (guide_px - 1) / 2,
                                   region_px // 2, region_px - 1 - region_px // 2)
    return (np.frombuffer(region, np.float64).reshape(rows, cols), np.frombuffer(guide, np.float64).reshape(rows, cols))
