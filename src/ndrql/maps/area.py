"""Exact area sums for resizing 2-D arrays in O(pixels): the planning grid's and the model input's arithmetic.

Output cell ``i`` of an axis of ``n_in`` pixels resized to ``n_out`` cells covers the input interval
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
