"""How a ``grid``-mode model sees a large planning grid: the *view* (studies/large_view/history.md).

The model was trained to see a planning grid at 4 px per cell (:func:`ndrql.dataset.render.grid_input`),
so a grid of 256 cells is a 1,024 px input. A view bounds what it sees:

- ``native``: 4 px per cell at every size (what ``ndrql plan`` does today);
- ``cap:K``: at most ``K`` px: ``min(4, K // n)`` px per cell (at least 1), so ``cap:512`` shows a
  256-cell grid at 2 px per cell and leaves grids up to 128 cells as they are;
- ``coarse:M``: grids above ``M`` cells are first merged ``f = ceil(n / M)`` x ``f`` cells into one (a
  merged cell is free when any of its cells is: every route of the grid stays open), the coarse grid is
  seen at 4 px per cell, and every cell takes its merged cell's prediction;
- ``walls:M``: as ``coarse:M``, but a merged cell is blocked when any of its cells is (a wall one cell
  thick stays a wall, where ``coarse`` opens it), unless that closes every route between start and goal;
  then as ``coarse``.

:func:`view_input` draws the model's input, :func:`view_cells` and :func:`view_distance_cells` bring
its outputs back to the planning grid, :func:`view_note` names the view in a summary. The views only change what is drawn, not the weights.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ndrql.dataset.render import (DISTANCE_UNIT, PX_PER_CELL, grid_input, manhattan_pixels, merge_cells, merged_grid,
                                  unknown_image)
from ndrql.errors import NdrqlError
from ndrql.maps.grid import area_downscale

Point = tuple[int, int]

#: Kinds of view (:class:`GridView`).
VIEW_KINDS = ("native", "cap", "coarse", "walls")


@dataclass(frozen=True)
class GridView:
    """A view: ``native``, ``cap`` with a largest input side ``limit`` in px, or ``coarse`` with a largest
    grid ``limit`` in cells."""

    kind: str = "native"
    limit: int = 0

    def __post_init__(self) -> None:
        if self.kind not in VIEW_KINDS:
            raise NdrqlError(f"unknown view {self.kind!r}; valid: native, cap:PX, coarse:CELLS, walls:CELLS")
        if (self.kind == "native") != (self.limit == 0) or self.kind != "native" and not 2 <= self.limit <= 4096:
            raise NdrqlError(f"view {self.kind} needs a limit of 2..4096, got {self.limit}")

    @classmethod
    def parse(cls, text: str) -> "GridView":
        """``"native"``, ``"cap:512"`` or ``"coarse:128"`` -> a view (one clear error otherwise)."""
        kind, _, limit = str(text).strip().partition(":")
        if kind == "native" and not limit:
            return cls()
        try:
            return cls(kind, int(limit))
        except ValueError:
            raise NdrqlError(f"view must be native, cap:PX, coarse:CELLS or walls:CELLS, got {text!r}") from None

    def __str__(self) -> str:
        return self.kind if self.kind == "native" else f"{self.kind}:{self.limit}"

    def factor(self, n: int) -> int:
        """Planning cells merged along each side into one cell the model sees (1 unless ``coarse`` or ``walls``
        and ``n > limit``)."""
        return -(-n // self.limit) if self.kind in ("coarse", "walls") and n > self.limit else 1

    def side(self, n: int) -> int:
        """Side in px of the model's input for a square grid of ``n`` cells."""
        seen = -(-n // self.factor(n))
        return self.px_per_cell(seen) * seen

    def shows_native(self, n: int) -> bool:
        """Whether a grid of ``n`` cells is seen as ``native`` sees it: nothing merged, 4 px per cell."""
        return self.factor(n) == 1 and self.px_per_cell(n) == PX_PER_CELL

    def px_per_cell(self, n: int) -> int:
        """Pixels per (possibly merged) cell in the model's input for a grid of ``n`` cells."""
        if self.kind == "cap":
            return int(np.clip(self.limit // max(1, n), 1, PX_PER_CELL))
        return PX_PER_CELL


def view_note(view: str, merged: int, lead: str = ", view ") -> str:
    """How a summary names the view a grid-mode model saw a grid through (``view`` as :class:`GridView` prints
    it, ``merged`` its :meth:`GridView.factor` on that grid): nothing where the model saw the grid as
    ``native`` shows it (``native``, or ``coarse`` on a grid it does not merge), else ``lead`` and the view,
    with e.g. ``", 2x2 cells seen as one"`` when it merged cells."""
    if view == "native" or (view.startswith(("coarse:", "walls:")) and merged == 1):
        return ""
    return f"{lead}{view}" + (f", {merged}x{merged} cells seen as one" if merged > 1 else "")


@dataclass(frozen=True)
class ViewInput:
    """The model's input for one planning grid and how to bring its outputs back."""

    image: np.ndarray
    """bool (side, side), True = obstacle."""
    start: Point
    goal: Point
    px: int
    """Pixels per seen cell."""
    factor: int
    """Planning cells per seen cell, along each side."""
    shape: tuple[int, int]
    """The planning grid's shape."""
    unknown: np.ndarray | None = None
    """bool (side, side): the unknown channel's pixels (:func:`~ndrql.dataset.render.unknown_image`), when the
    planning grid's unknown cells were given."""


def view_input(blocked: np.ndarray, start_cell: Point, goal_cell: Point, view: GridView = GridView(),
               unknown: np.ndarray | None = None) -> ViewInput:
    """The model's input for the planning grid ``blocked`` under ``view`` (``native``: :func:`grid_input` exactly);
    ``unknown``: the planning cells unknown to the planner (a merged cell is unknown when any of its cells is)."""
    n = max(np.shape(blocked))
    f = view.factor(n)
    seen = merged_grid(blocked, f, tuple(start_cell), tuple(goal_cell), view.kind == "walls")
    px = view.px_per_cell(max(seen.shape))
    s, g = (start_cell[0] // f, start_cell[1] // f), (goal_cell[0] // f, goal_cell[1] // f)
    img, s_px, g_px = grid_input(seen, s, g, max(seen.shape), px)
    hidden = None
    if unknown is not None:
        if np.shape(unknown) != np.shape(blocked):
            raise NdrqlError(f"unknown cells are {np.shape(unknown)}, the planning grid {np.shape(blocked)}")
        cells = ~merge_cells(~np.asarray(unknown, bool), f) if f > 1 else np.asarray(unknown, bool)
        hidden = unknown_image(cells[:seen.shape[0], :seen.shape[1]], seen, img.shape[0], px)
    return ViewInput(img, s_px, g_px, px, f, tuple(np.shape(blocked)), hidden)


def _to_grid(seen: np.ndarray, vi: ViewInput) -> np.ndarray:
    """Values per seen cell -> the planning grid (each cell takes its merged cell's value)."""
    if vi.factor == 1:
        return seen
    h, w = vi.shape
    return seen[(np.arange(h) // vi.factor)[:, None], (np.arange(w) // vi.factor)[None, :]]


def view_cells(prob: np.ndarray, vi: ViewInput) -> np.ndarray:
    """A probability output (side, side) -> the planning grid: the mean over each seen cell's pixels, then
    every planning cell its seen cell's value."""
    h, w = -(-vi.shape[0] // vi.factor), -(-vi.shape[1] // vi.factor)
    seen = area_downscale(np.asarray(prob, np.float64)[:h * vi.px, :w * vi.px], (h, w))
    return _to_grid(seen, vi)


def view_distance_cells(detour: np.ndarray, vi: ViewInput) -> np.ndarray:
    """The distance head's output (detour per pixel, :data:`~ndrql.dataset.render.DISTANCE_UNIT` units of the
    cells the model believes it sees, 4 px each) -> goal distance in planning cells per planning cell.

    The sum is taken in the detour's own precision (float32 from the model), as ``plan`` has always taken
    it, so that under ``native`` this is :func:`~ndrql.dataset.render.cell_means` of that sum bit for bit."""
    seen_moves = manhattan_pixels(vi.goal, vi.image.shape[0]) + DISTANCE_UNIT * np.asarray(detour)
    return view_cells(seen_moves, vi) * (PX_PER_CELL / vi.px) * vi.factor
