"""Test-time symmetry: the model's output averaged over the grid's symmetries.

Shortest paths commute with rotating and mirroring the grid (4-connected moves are the same in every
orientation), so a prediction for the turned grid, turned back, is another estimate of the same
answer. Averaging them cancels errors that depend on orientation (the network is not equivariant) at
the cost of one forward pass per orientation (one batch). Region and guideline probabilities are
averaged as probabilities; the distance output (a detour in cells) as it is.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

#: The eight symmetries of a square, ordered so that the first 1, 2, 4 or 8 are the ones used:
#: identity, transpose, half turn, transpose after a half turn (a group of four), then quarter turns.
ORDER = (0, 4, 2, 6, 1, 3, 5, 7)

#: Counts of orientations a prediction may average over.
COUNTS = (1, 2, 4, 8)

#: What ``ndrql plan`` and ``ndrql predict`` average over by default (docs/history.md#symmetry).
DEFAULT_COUNT = 4

Runner = Callable[[np.ndarray], tuple]


def check_count(count: object, error: type[Exception] = ValueError) -> int:
    """``count`` if it is one of :data:`COUNTS`, else ``error`` with one line saying which are."""
    if isinstance(count, bool) or count not in COUNTS:
        raise error(f"symmetries must be one of {', '.join(map(str, COUNTS))}, got {count!r}")
    return int(count)  # type: ignore[call-overload]


def digest_suffix(count: int) -> str:
    """What a count of orientations adds to the digest that names a model's cached predictions: nothing
    for the plain forward (so earlier caches stay valid), ``-sN`` otherwise."""
    return "" if check_count(count) == 1 else f"-s{count}"


def turn(x: np.ndarray, k: int) -> np.ndarray:
    """Symmetry ``k`` (0..7) of the last two axes: transposed when ``k & 4``, then ``k & 3`` quarter turns."""
    if k & 4:
        x = np.swapaxes(x, -1, -2)
    return np.rot90(x, k & 3, axes=(-2, -1))


def turn_back(x: np.ndarray, k: int) -> np.ndarray:
    """The inverse of :func:`turn` (``turn_back(turn(x, k), k) == x``)."""
    x = np.rot90(x, -(k & 3), axes=(-2, -1))
    return np.swapaxes(x, -1, -2) if k & 4 else x


def averaged(runner: Runner, x: np.ndarray, count: int) -> tuple:
    """``runner``'s outputs for ``x`` (B, C, S, S), averaged over the first ``count`` of :data:`ORDER`
    (all orientations in one batch of ``count * B``). ``count`` 1 is the plain forward."""
    if check_count(count) == 1:
        return runner(x)
    if x.shape[-1] != x.shape[-2]:
        raise ValueError(f"averaging over turns needs a square input, got {x.shape[-2]}x{x.shape[-1]}")
    ks = ORDER[:count]
    b = x.shape[0]
    outs = runner(np.concatenate([turn(x, k) for k in ks]))
    return tuple(None if o is None else
                 np.mean([turn_back(o[i * b:(i + 1) * b], k) for i, k in enumerate(ks)], axis=0).astype(o.dtype)
                 for o in outs)
