"""Occupancy maps and the 50x50 planning grid (docs/method.md).

A map is a boolean occupancy array, ``True`` = obstacle, addressed ``(row, col)``. The planning
grid is the map downscaled by exact area averaging; a cell is blocked when at least half of its
area is obstacle. Start and goal map to the cell containing the pixel's centre, and are snapped to
the nearest free cell (BFS, with a :class:`SnapWarning`) when that cell is blocked. Start and goal
must be 4-connected on the planning grid, otherwise :class:`~ndrql.errors.NoPathError`.
"""

from __future__ import annotations

import warnings
from collections import deque
from dataclasses import dataclass, field
from typing import Sequence, Tuple

import numpy as np

from ndrql.errors import NoPathError, PointError
from ndrql.maps.area import DENSE_AREA_MAX_MACS, _overlap_matrix, _overlap_sums, area_sums  # noqa: F401 (re-exported)
from ndrql.maps.fields import bfs4

Cell = Tuple[int, int]

#: Side of the paper's planning grid, in cells (its 201 px maps -> 50 x 50 cells).
PLANNING_SIZE = 50
#: Side of the paper's maps (the dataset's samples) and of the NDR model's input, in px.
MODEL_SIDE = 201

#: The four moves of the planning grid, in action order: up, down, left, right.
MOVES4: tuple[Cell, ...] = ((-1, 0), (1, 0), (0, -1), (0, 1))


class SnapWarning(UserWarning):
    """A start or goal fell in a blocked planning cell and was moved to the nearest free one."""


@dataclass(frozen=True)
class GridMap:
    """A boolean occupancy map: ``obstacles[row, col]`` is ``True`` on an obstacle.

    The array is copied and made read-only, so a ``GridMap`` never changes after construction.
    """

    obstacles: np.ndarray
    """Boolean array of shape (H, W), ``True`` = obstacle."""
    resolution: float | None = None
    """Metres per pixel (ROS maps), ``None`` when the source has no scale."""
    origin: tuple[float, ...] | None = None
    """World pose of the lower-left pixel, ``(x, y, yaw)`` (ROS maps), else ``None``."""
    source: str | None = None
    """Where the map came from (a path or a dataset sample id), for reports."""

    def __post_init__(self) -> None:
        arr = np.asarray(self.obstacles)
        if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1:
            raise ValueError(f"GridMap needs a non-empty 2-D array, got shape {arr.shape}")
        arr = np.array(arr, dtype=bool, copy=True)
        arr.setflags(write=False)
        object.__setattr__(self, "obstacles", arr)
        if self.origin is not None:
            object.__setattr__(self, "origin", tuple(float(v) for v in self.origin))

    @property
    def shape(self) -> tuple[int, int]:
        """``(height, width)`` in pixels."""
        return self.obstacles.shape  # type: ignore[return-value]

    @property
    def height(self) -> int:
        return int(self.obstacles.shape[0])

    @property
    def width(self) -> int:
        return int(self.obstacles.shape[1])

    @property
    def obstacle_ratio(self) -> float:
        """Fraction of pixels that are obstacles."""
        return float(self.obstacles.mean())

    def contains(self, point: Sequence[int]) -> bool:
        """Whether ``(row, col)`` lies on the map."""
        r, c = point
        return 0 <= r < self.height and 0 <= c < self.width

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, GridMap):
            return NotImplemented
        return (
            self.obstacles.shape == other.obstacles.shape
            and bool(np.array_equal(self.obstacles, other.obstacles))
            and self.resolution == other.resolution
            and self.origin == other.origin
        )

    __hash__ = None  # type: ignore[assignment]


# ---------------------------------------------------------------------------------------------
# Area averaging (the exact O(pixels) arithmetic lives in ndrql.maps.area)

def area_downscale(values: np.ndarray, shape: tuple[int, int] = (PLANNING_SIZE, PLANNING_SIZE)) -> np.ndarray:
    """Resize a 2-D array to ``shape`` by exact area averaging (each output = mean over its area).

    Used for the planning grid and for model outputs (docs/method.md). Works for any input size and
    aspect ratio, including non-integer ratios such as 201 -> 50, in O(pixels) time and memory (small
    inputs use the dense matrix form, see :data:`DENSE_AREA_MAX_MACS`; both agree to rounding).
    """
    arr = np.asarray(values, dtype=np.float64)
    if arr.ndim != 2:
        raise ValueError(f"area_downscale needs a 2-D array, got shape {arr.shape}")
    h_in, w_in = arr.shape
    h_out, w_out = int(shape[0]), int(shape[1])
    if h_out * h_in * w_in + h_out * w_in * w_out <= DENSE_AREA_MAX_MACS:
        rows = _overlap_matrix(h_in, h_out).astype(np.float64)
        cols = _overlap_matrix(w_in, w_out).astype(np.float64)
        return (rows @ arr @ cols.T) / float(h_in * w_in)
    return area_sums(arr, (h_out, w_out), np.float64) / float(h_in * w_in)


def planning_grid(obstacles: np.ndarray | GridMap, size: int | tuple[int, int] = PLANNING_SIZE) -> np.ndarray:
    """Blocked cells of the planning grid: area-average the obstacles, blocked where the mean >= 0.5.

    Computed in exact integer arithmetic, so a cell that is exactly half obstacle is blocked; O(pixels).
    """
    arr = obstacles.obstacles if isinstance(obstacles, GridMap) else np.asarray(obstacles)
    if arr.ndim != 2 or arr.size == 0:
        raise ValueError(f"planning_grid needs a non-empty 2-D array, got shape {arr.shape}")
    h_out, w_out = (size, size) if isinstance(size, int) else size
    h_in, w_in = arr.shape
    # obstacle area in units of 1/(h_out*w_out) px; it is at most h_in * w_in, so int32 is exact below 2**30 px
    acc = np.int32 if h_in * w_in < 1 << 30 else np.int64
    bits = (arr if arr.dtype == bool else arr != 0).view(np.uint8)  # 0/1 bytes: what group_sums packs
    area = area_sums(bits, (h_out, w_out), acc).astype(np.int64)
    return 2 * area >= h_in * w_in


def point_to_cell(point: Sequence[int], source_shape: tuple[int, int], grid_shape: tuple[int, int]) -> Cell:
    """The planning cell that contains the centre of source pixel ``(row, col)``."""
    r, c = int(point[0]), int(point[1])
    h_in, w_in = source_shape
    h_out, w_out = grid_shape
    if not (0 <= r < h_in and 0 <= c < w_in):
        raise PointError(f"point ({r}, {c}) is off the {h_in}x{w_in} map")
    return ((2 * r + 1) * h_out // (2 * h_in), (2 * c + 1) * w_out // (2 * w_in))


def cell_to_point(cell: Sequence[float], source_shape: tuple[int, int], grid_shape: tuple[int, int]) -> tuple[float, float]:
    """Centre of planning cell ``(row, col)`` in source-pixel coordinates (for drawing)."""
    h_in, w_in = source_shape
    h_out, w_out = grid_shape
    return ((cell[0] + 0.5) * h_in / h_out - 0.5, (cell[1] + 0.5) * w_in / w_out - 0.5)


# ---------------------------------------------------------------------------------------------
# Breadth-first search helpers


def bfs_distances(blocked: np.ndarray, source: Cell) -> np.ndarray:
    """4-connected move counts from ``source`` to every cell (``-1`` where unreachable or blocked), ``(h, w)`` int64.

    Compiled (:func:`ndrql.maps.fields.bfs4`: the C extension, else numba); :class:`IndexError` when ``source``
    is off the grid.
    """
    return bfs4(blocked, source)


def nearest_free_bfs(blocked: np.ndarray, cell: Cell) -> Cell:
    """Nearest free cell to ``cell`` by 4-connected BFS over the whole grid (obstacles are crossed).

    Ties go to the first cell found in move order up, down, left, right. ``cell`` itself when free.
    """
    blocked = np.asarray(blocked, dtype=bool)
    h, w = blocked.shape
    if not blocked[cell]:
        return (int(cell[0]), int(cell[1]))
    seen = np.zeros((h, w), dtype=bool)
    seen[cell] = True
    queue = deque([(int(cell[0]), int(cell[1]))])
    while queue:
        r, c = queue.popleft()
        for dr, dc in MOVES4:
            nr, nc = r + dr, c + dc
            if 0 <= nr < h and 0 <= nc < w and not seen[nr, nc]:
                if not blocked[nr, nc]:
                    return (nr, nc)
                seen[nr, nc] = True
                queue.append((nr, nc))
    raise NoPathError("the planning grid has no free cell at all")


def nearest_free_euclidean(obstacles: np.ndarray, p: Cell) -> Cell:
    """``p`` itself when free, else the free pixel nearest by Euclidean distance (first in row-major order on a tie).

    The rule for points on the model's input (:func:`ndrql.dataset.render.to_model_input`); planning
    cells snap by BFS steps (:func:`nearest_free_bfs`).
    """
    if not obstacles[p]:
        return p
    free = np.argwhere(~obstacles)
    if len(free) == 0:
        raise PointError("the map has no free cell")
    d = ((free - np.asarray(p)) ** 2).sum(1)
    r, c = free[int(np.argmin(d))]
    return (int(r), int(c))


def check_connected(blocked: np.ndarray, start: Cell, goal: Cell) -> None:
    """Raise :class:`NoPathError` unless ``start`` and ``goal`` are 4-connected through free cells."""
    dist = bfs_distances(blocked, start)
    if dist[goal] < 0:
        raise NoPathError(
            f"start {tuple(start)} and goal {tuple(goal)} are not 4-connected on the "
            f"{blocked.shape[0]}x{blocked.shape[1]} planning grid (a gap narrower than a cell closes at the >= 0.5 rule)"
        )


# ---------------------------------------------------------------------------------------------
# The planning problem


@dataclass(frozen=True)
class PlanningGrid:
    """A planning problem on the downscaled grid: blocked cells plus start and goal cells.

    Build it with :meth:`from_map`; ``start``/``goal`` are planning-grid ``(row, col)`` cells, already
    snapped to free cells and known to be 4-connected.
    """

    blocked: np.ndarray
    """Boolean array (h, w), ``True`` = blocked cell."""
    start: Cell
    """Start cell (row, col) on the planning grid."""
    goal: Cell
    """Goal cell (row, col) on the planning grid."""
    source_shape: tuple[int, int]
    """Shape (H, W) of the source map in pixels."""
    source_start: Cell
    """Start as given, in source-map pixels (row, col)."""
    source_goal: Cell
    """Goal as given, in source-map pixels (row, col)."""
    snapped: tuple[bool, bool] = field(default=(False, False))
    """Whether start, goal were moved off a blocked cell."""
    cell_px: tuple[float, float] | None = None
    """Cell size (rows, cols) in map pixels; ``None``: ``source_shape / shape`` (the area grid's cells)."""

    def __post_init__(self) -> None:
        arr = np.array(self.blocked, dtype=bool, copy=True)
        arr.setflags(write=False)
        object.__setattr__(self, "blocked", arr)

    @property
    def cell_size(self) -> tuple[float, float]:
        """Cell size (rows, cols) in map pixels."""
        if self.cell_px is not None:
            return (float(self.cell_px[0]), float(self.cell_px[1]))
        return (self.source_shape[0] / self.shape[0], self.source_shape[1] / self.shape[1])

    def centre(self, cell: Sequence[float]) -> tuple[float, float]:
        """Centre of planning cell ``(row, col)`` in map-pixel coordinates (pixel ``(r, c)``'s centre is ``(r, c)``)."""
        if self.cell_px is None:
            return cell_to_point(cell, self.source_shape, self.shape)
        sr, sc = self.cell_size
        return ((cell[0] + 0.5) * sr - 0.5, (cell[1] + 0.5) * sc - 0.5)

    @classmethod
    def from_map(
        cls,
        grid_map: GridMap | np.ndarray,
        start: Sequence[int],
        goal: Sequence[int],
        size: int | tuple[int, int] = PLANNING_SIZE,
        check: bool = True,
    ) -> "PlanningGrid":
        """Downscale ``grid_map``, map ``start``/``goal`` (source pixels, row-col) to cells, snap, check.

        Raises :class:`PointError` for a point off the map, :class:`NoPathError` when start and goal
        are not 4-connected (unless ``check=False``). Emits :class:`SnapWarning` when a point moves.
        """
        obstacles = grid_map.obstacles if isinstance(grid_map, GridMap) else np.asarray(grid_map, dtype=bool)
        blocked = planning_grid(obstacles, size)
        cells = []
        snapped = []
        for name, point in (("start", start), ("goal", goal)):
            if len(point) != 2:
                raise PointError(f"{name} must be (row, col), got {tuple(point)!r}")
            r, c = int(point[0]), int(point[1])
            if not (0 <= r < obstacles.shape[0] and 0 <= c < obstacles.shape[1]):
                raise PointError(
                    f"{name} ({r}, {c}) is off the map: rows 0..{obstacles.shape[0] - 1}, cols 0..{obstacles.shape[1] - 1}"
                )
            cell = point_to_cell((r, c), obstacles.shape, blocked.shape)
            free = nearest_free_bfs(blocked, cell)
            if free != cell:
                cr, cc = cell_to_point(free, obstacles.shape, blocked.shape)  # in map pixels, as the point was given
                warnings.warn(
                    f"{name} ({r}, {c}) falls in blocked planning cell {cell}; moved to nearest free cell {free}, "
                    f"centred at pixel ({cr:.0f}, {cc:.0f})",
                    SnapWarning,
                    stacklevel=2,
                )
            cells.append(free)
            snapped.append(free != cell)
        if check:
            check_connected(blocked, cells[0], cells[1])
        return cls(
            blocked=blocked,
            start=cells[0],
            goal=cells[1],
            source_shape=(int(obstacles.shape[0]), int(obstacles.shape[1])),
            source_start=(int(start[0]), int(start[1])),
            source_goal=(int(goal[0]), int(goal[1])),
            snapped=(snapped[0], snapped[1]),
        )

    @property
    def shape(self) -> tuple[int, int]:
        return self.blocked.shape  # type: ignore[return-value]

    def to_strings(self) -> list[str]:
        """The grid as text rows: ``#`` blocked, ``.`` free."""
        return grid_to_strings(self.blocked)


def grid_to_strings(blocked: np.ndarray, marks: dict[Cell, str] | None = None) -> list[str]:
    """Rows of text, ``#`` blocked and ``.`` free; ``marks`` overrides single cells (e.g. ``S``/``G``)."""
    rows = [["#" if b else "." for b in row] for row in np.asarray(blocked, dtype=bool)]
    for (r, c), ch in (marks or {}).items():
        rows[r][c] = ch
    return ["".join(row) for row in rows]
