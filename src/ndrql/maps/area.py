"""The two rules that resize a map, in O(pixels).

- **Exact area** (:func:`area_sums`; :func:`ndrql.maps.grid.area_downscale` and
  :func:`ndrql.maps.grid.planning_grid` use it): each output cell covers its exact share of the
  input, pixels split between cells where a boundary falls inside them. The planning grid (blocked
  where the obstacle area is >= half the cell) and every probability averaged onto a grid use it.
- **Whole pixels** (:func:`pixel_bins`, :func:`whole_pixel_majority`): each pixel goes wholly to one
  cell, a cell is blocked when at least half of its pixels are obstacles; growing, a cell takes one
  pixel. The model's input is resized this way (:func:`ndrql.dataset.render.to_model_input`): the
  shipped NDR models were trained on inputs resized by it, so the model keeps its own rule. The two
  agree when the sizes divide (402 -> 201) and differ at cells that straddle a pixel (256 -> 201).

Exact area: output cell ``i`` of an axis of ``n_in`` pixels resized to ``n_out`` cells covers the input interval
``[i * n_in / n_out, (i + 1) * n_in / n_out)``. Scaled by ``n_out`` this is ``[i * n_in, (i + 1) * n_in)``
and pixel ``j`` is ``[j * n_out, (j + 1) * n_out)``: overlaps are integers in units of ``1 / n_out`` pixel,
so sums of integer inputs are exact. The resize is separable (rows, then columns) and each pass costs
O(input + output): when shrinking, a pixel overlaps at most two cells; when growing, a cell at most
two pixels.
"""

from __future__ import annotations

import numpy as np

#: Largest dense product (multiply-adds) for which :func:`ndrql.maps.grid.area_downscale` keeps the dense matrix form on
#: float inputs: its BLAS summation order is what the paper-reproduction numbers were computed with
#: (201 -> 50 is 2.5 M), so those stay bit-identical; larger inputs take the O(pixels) separable form.
DENSE_AREA_MAX_MACS = 1 << 23


def _overlap_matrix(n_in: int, n_out: int) -> np.ndarray:
    """Integer overlaps, in units of ``1 / n_out`` input pixels, of input pixel ``j`` with output cell ``i``.

    Dense ``(n_out, n_in)``: only for small sizes (see :data:`DENSE_AREA_MAX_MACS`). Every row sums to ``n_in``.
    """
    i = np.arange(n_out, dtype=np.int64)[:, None]
    j = np.arange(n_in, dtype=np.int64)[None, :]
    lo = np.maximum(i * n_in, j * n_out)
    hi = np.minimum((i + 1) * n_in, (j + 1) * n_out)
    return np.maximum(hi - lo, 0)


def group_sums(x: np.ndarray, starts: np.ndarray, axis: int, acc: type) -> np.ndarray:
    """``np.add.reduceat(x, starts, axis, dtype=acc)``; for 0/1 ``uint8`` rows summed in groups of at most
    255, eight columns per 64-bit add (no byte lane can carry into the next), about 4x faster."""
    n = x.shape[axis]
    if axis == 0 and x.ndim == 2 and x.dtype == np.uint8 and x.shape[1] >= 8 and x.strides[1] == 1:
        if int(np.diff(np.append(starts, n)).max()) <= 255:
            w8 = x.shape[1] // 8 * 8
            out = np.empty((len(starts), x.shape[1]), dtype=acc)
            out[:, :w8] = np.add.reduceat(x[:, :w8].view(np.uint64), starts, axis=0).view(np.uint8)
            if w8 < x.shape[1]:
                out[:, w8:] = np.add.reduceat(x[:, w8:], starts, axis=0, dtype=acc)
            return out
    return np.add.reduceat(x, starts, axis=axis, dtype=acc)


def _overlap_sums(x: np.ndarray, n_out: int, axis: int, acc: type) -> np.ndarray:
    """``sum_j overlap(i, j) * x[.., j, ..]`` along ``axis`` (units of ``1 / n_out`` px), in dtype ``acc``.

    Equal to the dense product with :func:`_overlap_matrix` (exactly, for integer inputs) at O(x.size + output)
    time and memory.
    """
    n_in = x.shape[axis]
    i = np.arange(n_out, dtype=np.int64)
    shape = [1] * x.ndim
    shape[axis] = -1

    def weights(w: np.ndarray) -> np.ndarray:
        return w.astype(acc).reshape(shape)

    if n_in >= n_out:  # shrink: pixel j lies in cell (j * n_out) // n_in, the last pixel of a cell may straddle
        starts = -((-i * n_in) // n_out)  # first pixel starting inside cell i (every cell has one)
        out = group_sums(x, starts, axis, acc) * acc(n_out)
        last = np.append(starts[1:], n_in) - 1
        spill = (last + 1) * n_out - (i + 1) * n_in  # part of the last pixel that lies in cell i + 1
        sel = np.nonzero(spill[:-1] > 0)[0]
        if sel.size:
            d = np.take(x, last[sel], axis=axis).astype(acc) * weights(spill[sel])
            idx = [slice(None)] * x.ndim
            idx[axis] = sel
            out[tuple(idx)] -= d
            idx[axis] = sel + 1
            out[tuple(idx)] += d
        return out
    # grow: cell i starts in pixel b and may reach into pixel b + 1
    b = (i * n_in) // n_out
    first = np.minimum((b + 1) * n_out, (i + 1) * n_in) - i * n_in
    out = np.take(x, b, axis=axis).astype(acc) * weights(first)
    rest = n_in - first
    sel = np.nonzero(rest > 0)[0]
    if sel.size:
        idx = [slice(None)] * x.ndim
        idx[axis] = sel
        out[tuple(idx)] += np.take(x, b[sel] + 1, axis=axis).astype(acc) * weights(rest[sel])
    return out


def area_sums(values: np.ndarray, shape: tuple[int, int], acc: type = np.int64) -> np.ndarray:
    """Area-weighted sums of ``values`` over the cells of a ``shape`` resize, in units of
    ``1 / (shape[0] * shape[1])`` pixel (divide by the input's pixel count for the mean). Exact for
    integer or boolean inputs with ``acc=np.int64``; O(pixels) time and memory (the axis whose pass leaves the
    smaller intermediate goes first, so a 1 x 16 M map never becomes 50 x 16 M)."""
    x = np.asarray(values)
    h_out, w_out = int(shape[0]), int(shape[1])
    if h_out * x.shape[1] <= x.shape[0] * w_out:  # resize the axis that keeps the intermediate smaller first
        return _overlap_sums(_overlap_sums(x, h_out, 0, acc), w_out, 1, acc)
    return _overlap_sums(_overlap_sums(x, w_out, 1, acc), h_out, 0, acc)


def pixel_bins(n_in: int, n_out: int) -> np.ndarray:
    """For each of ``n_in`` pixels of an axis, the one of ``n_out`` cells it goes to whole: ``floor(j * n_out / n_in)``.

    Read the other way (``pixel_bins(n_out, n_in)``) it is the pixel each cell samples when an axis grows.
    """
    return np.minimum((np.arange(n_in) * n_out) // n_in, n_out - 1)


def whole_pixel_majority(obstacles: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """A bool map resized to ``shape`` by whole pixels (module docstring): shrinking both axes, a cell is
    blocked when at least half of the pixels of its :func:`pixel_bins` are obstacles; otherwise each
    cell takes the pixel it samples (nearest). O(pixels) time and memory: the bins are contiguous runs
    of pixels, so each axis is one ``reduceat`` pass."""
    obstacles = np.asarray(obstacles, bool)
    (h, w), (nh, nw) = obstacles.shape, shape
    if h >= nh and w >= nw:
        r0 = np.searchsorted(pixel_bins(h, nh), np.arange(nh))  # first pixel of each bin (every bin has one)
        c0 = np.searchsorted(pixel_bins(w, nw), np.arange(nw))
        rows_sum = group_sums(np.ascontiguousarray(obstacles).view(np.uint8), r0, 0, np.int64)
        sums = np.add.reduceat(rows_sum, c0, axis=1).astype(np.float64)
        counts = np.outer(np.diff(np.append(r0, h)), np.diff(np.append(c0, w))).astype(np.float64)
        return sums / np.maximum(counts, 1) >= 0.5
    return obstacles[pixel_bins(nh, h)[:, None], pixel_bins(nw, w)[None, :]]
