"""Bounds on the environments' arguments, checked in their constructors and ``reset`` (one :class:`NdrqlError` line).

The same bounds as the CLI: a planning grid of 2..:data:`ndrql.limits.MAX_GRID_SIZE` cells a side,
points as integer ``(row, col)`` pairs (``0.7`` is not a row), seeds ``0 <= seed < 2**63``, finite
per-cell rewards, a drawing scale and generated map sides that keep memory in proportion.
"""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np

from ndrql.errors import NdrqlError, PointError, brief
from ndrql.limits import MAX_GRID_SIZE, SEED_LIMIT, check_cell

#: Largest ``cell_px`` (pixels per cell when rendering): a 1024-cell grid at 64 px is 65,536 px a side.
MAX_CELL_PX = 64
#: Largest side of a rendered frame (pixels): ``cell_px`` times the grid's longer side.
MAX_FRAME_PX = 8192
#: Largest generated map side (``map_px``), as the readers' default limit (4096 x 4096 pixels).
MAX_MAP_PX = 4096


def _int(value: Any, name: str, lo: int, hi: int, error: type[NdrqlError] = NdrqlError) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not lo <= int(value) <= hi:
        raise error(f"{name} must be an integer in {lo}..{hi:,}, got {brief(value)}")
    return int(value)


def check_size(size: Any) -> int:
    """Cells on the planning grid's longer side."""
    return _int(size, "size", 2, MAX_GRID_SIZE)


def check_cell_px(cell_px: Any) -> int:
    """Pixels per cell in ``rgb_array`` rendering."""
    return _int(cell_px, "cell_px", 1, MAX_CELL_PX)


def check_grid_shape(grid: Any) -> None:
    """A ``grid`` given in cells: at most :data:`ndrql.limits.MAX_GRID_SIZE` a side (``None`` passes)."""
    if grid is not None:
        shape = np.shape(grid)
        if len(shape) == 2 and max(shape) > MAX_GRID_SIZE:
            raise NdrqlError(f"grid must be at most {MAX_GRID_SIZE} cells a side, got {shape[0]}x{shape[1]}")


def check_frame(cell_px: int, shape: tuple[int, ...]) -> None:
    """``rgb_array`` frames of at most :data:`MAX_FRAME_PX` a side."""
    if cell_px * max(shape) > MAX_FRAME_PX:
        raise NdrqlError(f"cell_px {cell_px} on a {shape[0]}x{shape[1]} grid draws frames of {cell_px * max(shape):,} px "
                         f"a side, more than {MAX_FRAME_PX:,}; give a smaller cell_px")


def check_map_px(map_px: Any, size: int) -> int | None:
    """Side of a generated map in pixels (``None``: 4 x size); at least the grid's side."""
    return None if map_px is None else _int(map_px, "map_px", size, MAX_MAP_PX)


def check_point(point: Any, name: str) -> tuple[int, int] | None:
    """``(row, col)`` as integers (``None`` passes); :func:`ndrql.limits.check_cell`'s rule, as :class:`PointError`."""
    if point is None:
        return None
    try:
        return check_cell(point, name)
    except ValueError as exc:
        raise PointError(str(exc)) from None


def check_seed(seed: Any) -> None:
    """``reset(seed=...)``: ``None`` or an integer in ``0 .. 2**63 - 1`` (the CLI's range)."""
    if seed is not None:
        _int(seed, "seed", 0, SEED_LIMIT - 1)


def check_rewards(r_c: np.ndarray) -> np.ndarray:
    """Per-cell rewards: every value finite."""
    if not np.isfinite(r_c).all():
        raise NdrqlError("r_c must hold finite rewards (no NaN or infinity)")
    return r_c


def check_options(options: dict[str, Any] | None, valid: tuple[str, ...]) -> dict[str, Any]:
    """``options`` as a dict after refusing keys other than ``valid`` (one clear :class:`NdrqlError`)."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise NdrqlError(f"reset options must be a dict, got {type(options).__name__}")
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise NdrqlError(f"unknown reset option {', '.join(map(repr, unknown))}; valid: {', '.join(valid)}")
    return options


def reset_options(options: dict[str, Any] | None, valid: tuple[str, ...]) -> dict[str, Any]:
    """``reset(options=...)`` of either env: :func:`check_options`, then ``start`` and ``goal`` as points
    (:func:`check_point`); each env checks its own other keys."""
    opts = check_options(options, valid)
    for name in ("start", "goal"):
        check_point(opts.get(name), name)
    return opts
