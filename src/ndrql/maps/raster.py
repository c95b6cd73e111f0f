"""Thick polylines rasterised exactly like OpenCV's ``cv2.line`` (``LINE_8``), without OpenCV.

The path-planning dataset drew its guideline labels with
``cv2.line(img, (col0, row0), (col1, row1), 255, thickness=2)`` per waypoint pair. OpenCV is only a
test dependency of ndrql, so this module re-implements that drawing in integer arithmetic, step by
step as OpenCV does it:

- end points go to 16-bit fixed point (``p << 16``; here ``round(p * 65536)``, so float points
  behave as ``cv2.line(..., shift=16)`` would and integer points exactly as ``shift=0``);
- a line of thickness ``t >= 2`` is the convex quadrilateral ``p0 +- d, p1 -+ d``, with ``d`` the
  perpendicular of length ``t / 2`` rounded to fixed point, filled scanline by scanline with edges
  stepped in fixed point (OpenCV's ``FillConvexPoly``), its four sides also drawn as fixed-point
  lines (``Line2``), and a filled midpoint circle of radius ``(t + 1) // 2`` (a plus sign for
  ``t = 2``) at each rounded end point (``Circle``);
- a line of thickness 1 is OpenCV's 8-connected Bresenham line between the rounded end points.

Integer division truncates toward zero and ``>>`` is an arithmetic shift, as in C. Everything is
clipped to the image. Coordinates here are ``(row, col)``; OpenCV's ``x`` is the column.
Checked pixel for pixel against ``cv2.line`` in ``tests/test_synth_labels.py``. Numba-compiled
(``cache=True``); importing this module imports numba.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

SHIFT = 16
ONE = 1 << SHIFT
HALF = ONE >> 1


@nb.njit(cache=True)
def _cdiv(a, b):
    """C integer division (truncates toward zero)."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b >= 0) else -q


@nb.njit(cache=True)
def _put(img, x, y):
    if 0 <= y < img.shape[0] and 0 <= x < img.shape[1]:
        img[y, x] = True


@nb.njit(cache=True)
def _hline(img, y, x1, x2):
    if 0 <= y < img.shape[0]:
        x1 = max(x1, 0)
        x2 = min(x2, img.shape[1] - 1)
        for x in range(x1, x2 + 1):
            img[y, x] = True


@nb.njit(cache=True)
def _outcode(x, y, right, bottom):
    return (x < 0) + (x > right) * 2 + (y < 0) * 4 + (y > bottom) * 8


@nb.njit(cache=True)
def _clip(width, height, x1, y1, x2, y2):
    """OpenCV's ``clipLine`` on a ``width`` x ``height`` box: ``(inside, x1, y1, x2, y2)``."""
    right, bottom = width - 1, height - 1
    c1 = _outcode(x1, y1, right, bottom)
    c2 = _outcode(x2, y2, right, bottom)
    if (c1 & c2) == 0 and (c1 | c2) != 0:
        if c1 & 12:
            a = 0 if c1 < 8 else bottom
            x1 += _cdiv((a - y1) * (x2 - x1), y2 - y1)
            y1 = a
            c1 = (x1 < 0) + (x1 > right) * 2
        if c2 & 12:
            a = 0 if c2 < 8 else bottom
            x2 += _cdiv((a - y2) * (x2 - x1), y2 - y1)
            y2 = a
            c2 = (x2 < 0) + (x2 > right) * 2
        if (c1 & c2) == 0 and (c1 | c2) != 0:
            if c1:
                a = 0 if c1 == 1 else right
                y1 += _cdiv((a - x1) * (y2 - y1), x2 - x1)
                x1 = a
                c1 = 0
            if c2:
                a = 0 if c2 == 1 else right
                y2 += _cdiv((a - x2) * (y2 - y1), x2 - x1)
                x2 = a
                c2 = 0
    return (c1 | c2) == 0, x1, y1, x2, y2


@nb.njit(cache=True)
def _line_fixed(img, x1, y1, x2, y2):
    """A line between fixed-point end points, one pixel per major-axis step (OpenCV ``Line2``)."""
    h, w = img.shape
    inside, x1, y1, x2, y2 = _clip(np.int64(w) << SHIFT, np.int64(h) << SHIFT, x1, y1, x2, y2)
    if not inside:
        return
    dx, dy = x2 - x1, y2 - y1
    ax, ay = abs(dx), abs(dy)
    if ax > ay:
        if dx < 0:
            x1, x2, y1, y2 = x2, x1, y2, y1
            dy = -dy
        x_step, y_step = ONE, _cdiv(dy << SHIFT, ax | 1)
        ecount = (x2 - x1) >> SHIFT
    else:
        if dy < 0:
            x1, x2, y1, y2 = x2, x1, y2, y1
            dx = -dx
        x_step, y_step = _cdiv(dx << SHIFT, ay | 1), ONE
        ecount = (y2 - y1) >> SHIFT
    x1 += HALF
    y1 += HALF
    _put(img, (x2 + HALF) >> SHIFT, (y2 + HALF) >> SHIFT)
    if ax > ay:
        x1 >>= SHIFT
        while ecount >= 0:
            _put(img, x1, y1 >> SHIFT)
            x1 += 1
            y1 += y_step
            ecount -= 1
    else:
        y1 >>= SHIFT
        while ecount >= 0:
            _put(img, x1 >> SHIFT, y1)
            x1 += x_step
            y1 += 1
            ecount -= 1


@nb.njit(cache=True)
def _line_bresenham(img, x1, y1, x2, y2):
    """OpenCV's 8-connected integer line (``LineIterator``, left to right), clipped to the image."""
    h, w = img.shape
    if not (0 <= x1 < w and 0 <= x2 < w and 0 <= y1 < h and 0 <= y2 < h):
        inside, x1, y1, x2, y2 = _clip(w, h, x1, y1, x2, y2)
        if not inside:
            return
    if x2 < x1:
        x1, y1, x2, y2 = x2, y2, x1, y1
    dx, dy = x2 - x1, y2 - y1
    sy = 1 if dy >= 0 else -1
    dy = abs(dy)
    steep = dy > dx
    if steep:
        dx, dy = dy, dx
    err = dx - (dy + dy)
    plus, minus = dx + dx, -(dy + dy)
    x, y = x1, y1
    for _ in range(dx + 1):
        _put(img, x, y)
        mask = -1 if err < 0 else 0
        err += minus + (plus & mask)
        if steep:  # the "plus" step moves along the minor axis
            y += sy
            x += 1 if mask else 0
        else:
            x += 1
            y += sy if mask else 0


@nb.njit(cache=True)
def _fill_convex(img, vx, vy):
    """OpenCV ``FillConvexPoly`` (``LINE_8``, fixed-point vertices): edges, then scanlines."""
    h, w = img.shape
    npts = vx.shape[0]
    imin = 0
    xmin = xmax = vx[0]
    ymin = ymax = vy[0]
    px, py = vx[npts - 1], vy[npts - 1]
    for i in range(npts):
        if vy[i] < ymin:
            ymin = vy[i]
            imin = i
        ymax = max(ymax, vy[i])
        xmax = max(xmax, vx[i])
        xmin = min(xmin, vx[i])
        _line_fixed(img, px, py, vx[i], vy[i])
        px, py = vx[i], vy[i]
    xmin = (xmin + HALF) >> SHIFT
    xmax = (xmax + HALF) >> SHIFT
    ymin = (ymin + HALF) >> SHIFT
    ymax = (ymax + HALF) >> SHIFT
    if npts < 3 or xmax < 0 or ymax < 0 or xmin >= w or ymin >= h:
        return
    ymax = min(ymax, h - 1)
    e_idx = np.array([imin, imin], dtype=np.int64)
    e_di = np.array([1, npts - 1], dtype=np.int64)
    e_x = np.array([-ONE, -ONE], dtype=np.int64)
    e_dx = np.zeros(2, dtype=np.int64)
    e_ye = np.array([ymin, ymin], dtype=np.int64)
    edges = npts
    y = ymin
    while True:
        for i in range(2):
            if y >= e_ye[i]:
                idx0 = e_idx[i]
                idx = idx0 + e_di[i]
                if idx >= npts:
                    idx -= npts
                while edges > 0:
                    edges -= 1
                    ty = (vy[idx] + HALF) >> SHIFT
                    if ty > y:
                        xs, xe = vx[idx0], vx[idx]
                        e_ye[i] = ty
                        e_dx[i] = _cdiv((xe - xs) * 2 + (ty - y), 2 * (ty - y))
                        e_x[i] = xs
                        e_idx[i] = idx
                        break
                    idx0 = idx
                    idx += e_di[i]
                    if idx >= npts:
                        idx -= npts
                else:
                    edges -= 1  # the C loop's final failed ``edges-- > 0`` test
        if edges < 0:
            break
        if y >= 0:
            left, right = (1, 0) if e_x[0] > e_x[1] else (0, 1)
            xx1 = (e_x[left] + HALF) >> SHIFT
            xx2 = (e_x[right] + HALF) >> SHIFT
            if xx2 >= 0 and xx1 < w:
                _hline(img, y, xx1, xx2)
        e_x[0] += e_dx[0]
        e_x[1] += e_dx[1]
        y += 1
        if y > ymax:
            break


@nb.njit(cache=True)
def _circle(img, cx, cy, radius):
    """OpenCV's filled midpoint circle (``Circle`` with ``fill``)."""
    err, dx, dy, plus, minus = 0, radius, 0, 1, (radius << 1) - 1
    while dx >= dy:
        _hline(img, cy - dy, cx - dx, cx + dx)
        _hline(img, cy + dy, cx - dx, cx + dx)
        _hline(img, cy - dx, cx - dy, cx + dy)
        _hline(img, cy + dx, cx - dy, cx + dy)
        dy += 1
        err += plus
        plus += 2
        mask = -1 if err > 0 else 0
        err -= minus & mask
        dx += mask
        minus -= mask & 2


@nb.njit(cache=True)
def _thick_line(img, x0, y0, x1, y1, thickness):
    """OpenCV ``ThickLine`` for ``LINE_8`` with both end caps; points in fixed point."""
    if thickness <= 1:
        _line_bresenham(img, (x0 + HALF) >> SHIFT, (y0 + HALF) >> SHIFT, (x1 + HALF) >> SHIFT, (y1 + HALF) >> SHIFT)
        return
    fdx = (x0 - x1) / ONE
    fdy = (y1 - y0) / ONE
    r = fdx * fdx + fdy * fdy
    odd = thickness & 1
    half_t = np.int64(thickness) << (SHIFT - 1)
    if abs(r) > 2.220446049250313e-16:
        r = (half_t + odd * ONE * 0.5) / math.sqrt(r)
        dpx = np.int64(np.rint(fdy * r))
        dpy = np.int64(np.rint(fdx * r))
        vx = np.array([x0 + dpx, x0 - dpx, x1 - dpx, x1 + dpx], dtype=np.int64)
        vy = np.array([y0 + dpy, y0 - dpy, y1 - dpy, y1 + dpy], dtype=np.int64)
        _fill_convex(img, vx, vy)
    radius = (half_t + HALF) >> SHIFT
    _circle(img, (x0 + HALF) >> SHIFT, (y0 + HALF) >> SHIFT, radius)
    _circle(img, (x1 + HALF) >> SHIFT, (y1 + HALF) >> SHIFT, radius)


@nb.njit(cache=True)
def _polyline(img, fixed, thickness):
    n = fixed.shape[0]
    if n == 1:
        _thick_line(img, fixed[0, 1], fixed[0, 0], fixed[0, 1], fixed[0, 0], thickness)
    for k in range(n - 1):
        _thick_line(img, fixed[k, 1], fixed[k, 0], fixed[k + 1, 1], fixed[k + 1, 0], thickness)


def to_fixed(points: np.ndarray) -> np.ndarray:
    """``(row, col)`` points to OpenCV's 16-bit fixed point (exact for integers and multiples of 2**-16)."""
    return np.rint(np.asarray(points, dtype=np.float64).reshape(-1, 2) * ONE).astype(np.int64)


def draw_polyline(shape: tuple[int, int], points: np.ndarray, thickness: int) -> np.ndarray:
    """A bool image of ``shape`` with ``cv2.line(img, p[k], p[k + 1], 255, thickness)`` drawn for each pair.

    ``points`` are ``(row, col)``, integer or float (floats as with ``shift=16``); a single point is
    drawn as a zero-length line (its end cap). ``thickness`` must be at least 1.
    """
    if int(thickness) < 1:
        raise ValueError(f"thickness must be >= 1, got {thickness}")
    img = np.zeros((int(shape[0]), int(shape[1])), dtype=np.bool_)
    pts = np.asarray(points)
    if pts.size == 0:
        return img
    if not np.all(np.isfinite(pts)):
        raise ValueError("polyline points must be finite")
    _polyline(img, to_fixed(pts), int(thickness))
    return img
