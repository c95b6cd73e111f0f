"""Placing start and goal on the safe grid, and ``--size auto``: the coarsest safe grid that keeps the route.

The safe grid (:mod:`ndrql.maps.safe`) closes every passage narrower than a cell. Coarse grids make
Q-learning fast, fine grids keep narrow corridors open; :func:`choose_size` walks up a ladder of
sizes (:data:`SIZE_LADDER`) and takes the first on which start and goal are connected and the grid's
shortest route is at most :data:`AUTO_TOLERANCE` longer than the map's own shortest route (so no
corridor that matters was closed). Both routes are measured the same way, so the comparison sees
closed corridors and not the difference between 4- and 8-connected moves:

- on the map: 8-connected octile length, no corner cutting, on the full-resolution map after
  inflation (:func:`~ndrql.maps.astar.shortest_path8`), in pixels;
- on the grid: the same octile search between the start and goal cells, times the cell side, plus
  the straight distances from the start and goal pixels to the centres of their cells.

Why 8 %: the grid route runs through cell centres, so it pays up to about one cell per door or turn
and half a cell at each end; on the office maps of the tests and the docs that quantisation stays
below 5 % at the chosen size, while a closed door or corridor forces a detour through another one
that costs far more (typically 20 % and up). The learned path is then shortcut on the full map
anyway, which removes most of the quantisation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ndrql.errors import NoPathError, PointError
from ndrql.limits import MAX_GRID_SIZE
from ndrql.maps.astar import shortest_path8
from ndrql.maps.grid import Cell, PlanningGrid, nearest_free_bfs
from ndrql.maps.lines import segment_free
from ndrql.maps.safe import cell_centre, cell_size_px, conservative_grid, grid_shape, point_to_square_cell

#: Grid sizes ``--size auto`` tries, coarsest first (cells on the map's longer side).
SIZE_LADDER: tuple[int, ...] = (32, 40, 50, 64, 80, 100, 128, 160, 200, 256, 320, 400, 512)
#: How much longer than the map's own shortest route the grid's route may be (relative).
AUTO_TOLERANCE = 0.08


@dataclass(frozen=True)
class SizeTrial:
    """One grid size tried by :func:`choose_size`."""

    size: int
    """Cells on the map's longer side."""
    shape: tuple[int, int]
    """Grid shape (rows, cols)."""
    cell_px: float
    """Cell side in map pixels."""
    grid_length: float | None
    """The grid's shortest route in pixels (octile moves x cell side + the two end connections); None: not connected."""
    ratio: float | None
    """``grid_length / full_length``; None when not connected."""


@dataclass(frozen=True)
class SizeChoice:
    """The result of :func:`choose_size`."""

    size: int
    """The chosen size (cells on the longer side)."""
    full_length: float
    """The map's own shortest route (8-connected octile, after inflation), in pixels."""
    trials: tuple[SizeTrial, ...]
    """Every size tried, in order; the last one is the chosen one."""
    within_tolerance: bool
    """False when no size up to the limit kept the route within the tolerance (the closest connected one is used)."""
    tolerance: float = AUTO_TOLERANCE
    """The tolerance the sizes were held to."""
    own_pixels: bool = False
    """True when no size up to the limit kept the route within the tolerance and the grid is the map's own
    pixels (one pixel per cell, beyond the limit but within :data:`~ndrql.limits.MAX_GRID_SIZE`)."""

    @property
    def chosen(self) -> SizeTrial:
        return next(t for t in self.trials if t.size == self.size)


def full_route(free_check: np.ndarray, start: Sequence[int], goal: Sequence[int], radius_px: float = 0.0):
    """The map's own shortest route (8-connected, octile, no corner cutting) on ``free_check``.

    Raises :class:`NoPathError` when start and goal are not connected on the map itself.
    """
    try:
        return shortest_path8(free_check, start, goal)
    except NoPathError:
        robot = f" with obstacles inflated by the robot radius ({radius_px:.1f} px)" if radius_px >= 1 else ""
        raise NoPathError(f"start {tuple(start)} and goal {tuple(goal)} are not connected on the map itself{robot}; "
                          f"no planning grid can connect them") from None


def connected4(blocked: np.ndarray, a: Cell, b: Cell) -> bool:
    """Whether free cells ``a`` and ``b`` are 4-connected through free cells.

    Asked of the compiled A* (:func:`~ndrql.maps.astar.shortest_path8`): 8-connected moves without corner
    cutting join exactly the cells that 4-connected moves join, and the search is already loaded for the
    size search, where a connected-component labelling would import scipy (about 0.2 s) for one answer.
    """
    if blocked[tuple(a)] or blocked[tuple(b)]:
        return False
    try:
        shortest_path8(blocked, a, b)
    except NoPathError:
        return False
    return True


def place_point(free_check: np.ndarray, blocked: np.ndarray, point: Sequence[int], size: int,
                reach: int = 3) -> tuple[Cell, bool]:
    """The planning cell for map pixel ``point`` on a safe grid, and whether it had to move.

    The cell containing the point when it is free. Otherwise the free cell within ``reach`` cells
    whose centre is nearest to the point and can be reached from it in a straight line on the map
    ``free_check`` (``True`` = obstacle); failing that, the nearest free cell by grid distance.
    """
    shape = free_check.shape
    cell = point_to_square_cell(point, shape, size)
    if not blocked[cell]:
        return cell, False
    rows, cols = blocked.shape
    cands = []
    for i in range(max(0, cell[0] - reach), min(rows, cell[0] + reach + 1)):
        for j in range(max(0, cell[1] - reach), min(cols, cell[1] + reach + 1)):
            if not blocked[i, j]:
                cr, cc = cell_centre((i, j), shape, size)
                cands.append((math.hypot(cr - point[0], cc - point[1]), i, j))
    for _, i, j in sorted(cands):
        if segment_free(free_check, point, cell_centre((i, j), shape, size)):
            return (i, j), True
    return nearest_free_bfs(blocked, cell), True


def safe_grid(free_check: np.ndarray, size: int, start: Sequence[int], goal: Sequence[int]) -> PlanningGrid:
    """The safe planning grid of ``size`` cells on the map's longer side, with start and goal placed on it.

    The one builder every caller goes through (``plan``, ``astar``, ``predict``, the envs, the dataset's
    ``grid`` mode, the experiments, ``--size auto``): the blocked cells are
    :func:`~ndrql.maps.safe.conservative_grid` of ``free_check`` (``True`` = obstacle, already inflated by
    the robot's radius), each map pixel ``start``/``goal`` goes to its cell or, when that is blocked, to a
    nearby free cell (:func:`place_point`; :attr:`PlanningGrid.snapped` says which moved). Connectivity is
    the caller's to check (each says it its own way); :class:`NoPathError` when no cell is free.
    """
    size = int(size)
    blocked = conservative_grid(free_check, size)
    s_cell, s_moved = place_point(free_check, blocked, start, size)
    g_cell, g_moved = place_point(free_check, blocked, goal, size)
    s = cell_size_px(free_check.shape, size)
    return PlanningGrid(blocked=blocked, start=s_cell, goal=g_cell, source_shape=tuple(free_check.shape),
                        source_start=tuple(start), source_goal=tuple(goal), snapped=(s_moved, g_moved), cell_px=(s, s))


def grid_route_length(blocked: np.ndarray, start_cell: Cell, goal_cell: Cell, cell_px: float,
                      start_px: Sequence[float], goal_px: Sequence[float], centre_start: Sequence[float],
                      centre_goal: Sequence[float]) -> float | None:
    """Octile length of the grid's shortest route in pixels, with the straight end connections; None if disconnected."""
    try:
        route = shortest_path8(blocked, start_cell, goal_cell)
    except NoPathError:
        return None
    ends = math.dist(start_px, centre_start) + math.dist(goal_px, centre_goal)
    return route.cost * cell_px + ends


def try_size(free_check: np.ndarray, start: Sequence[int], goal: Sequence[int], size: int,
             full_length: float) -> SizeTrial:
    """Build the safe grid of ``size`` on ``free_check`` (obstacles already inflated) and measure its route."""
    shape = free_check.shape
    cell_px = cell_size_px(shape, size)
    try:
        pg = safe_grid(free_check, size, start, goal)
    except NoPathError:  # every cell blocked at this size (corridors narrower than a cell): finer sizes may open
        return SizeTrial(size=int(size), shape=grid_shape(shape, size), cell_px=cell_px, grid_length=None, ratio=None)
    blocked, s_cell, g_cell = pg.blocked, pg.start, pg.goal
    length = None
    if s_cell != g_cell:
        length = grid_route_length(blocked, s_cell, g_cell, cell_px, start, goal,
                                   cell_centre(s_cell, shape, size), cell_centre(g_cell, shape, size))
    ratio = None if length is None or full_length <= 0 else length / full_length
    return SizeTrial(size=int(size), shape=blocked.shape, cell_px=cell_px, grid_length=length, ratio=ratio)


def ladder(shape: Sequence[int], max_size: int) -> tuple[int, ...]:
    """The sizes :func:`choose_size` tries for a map of ``shape``: :data:`SIZE_LADDER` up to ``max_size``
    (``max_size`` itself included), and never cells smaller than one pixel."""
    top = min(int(max_size), max(int(shape[0]), int(shape[1])))
    sizes = [s for s in SIZE_LADDER if s <= top]
    if not sizes or sizes[-1] != top:
        sizes.append(top)
    out = []
    for s in sizes:
        try:
            grid_shape(shape, s)
        except Exception:  # too thin for this size: finer sizes may still fit
            continue
        out.append(s)
    return tuple(out)


def choose_size(free_check: np.ndarray, start: Sequence[int], goal: Sequence[int], full_length: float,
                max_size: int, tolerance: float = AUTO_TOLERANCE, resolution: float | None = None) -> SizeChoice:
    """The smallest ladder size whose grid keeps start and goal connected with a route within ``tolerance``.

    ``free_check``: the full-resolution map after inflation (``True`` = obstacle); ``full_length``: its
    shortest route in pixels (:func:`~ndrql.maps.astar.shortest_path8` cost). When no size is within
    the tolerance, the map's own pixels are tried next (one pixel per cell: every connection of the map
    survives) if the map's longer side is beyond ``max_size`` but within :data:`~ndrql.limits.MAX_GRID_SIZE`
    (``own_pixels=True``); failing that, the connected size with the best ratio is chosen
    (``within_tolerance=False``). When none is connected, :class:`NoPathError` says where the narrowest
    passage is, how wide, in pixels and metres (``resolution``, metres per pixel), and what to pass.
    """
    if tuple(int(v) for v in start) == tuple(int(v) for v in goal):  # every grid puts them in one cell
        raise PointError(f"start and goal are the same pixel {tuple(int(v) for v in start)}, so they fall in the same "
                         f"planning cell at any grid size; nothing to plan (give two different points)")
    trials: list[SizeTrial] = []
    sizes = ladder(free_check.shape, max_size)
    if not sizes:
        h, w = free_check.shape
        raise NoPathError(f"a {h}x{w} map is too thin for square cells up to {max_size} on its longer side "
                          f"(a cell must be at most twice the shorter side); crop it or use --grid area")
    for size in sizes:
        t = try_size(free_check, start, goal, size, full_length)
        trials.append(t)
        if t.ratio is not None and t.ratio <= 1.0 + tolerance:
            return SizeChoice(size=size, full_length=full_length, trials=tuple(trials), within_tolerance=True,
                              tolerance=tolerance)
    own = max(free_check.shape)
    if sizes[-1] < own <= MAX_GRID_SIZE:  # one pixel per cell: the grid is the map, so it connects what the map does
        t = try_size(free_check, start, goal, own, full_length)
        trials.append(t)
        if t.ratio is not None and t.ratio <= 1.0 + tolerance:
            return SizeChoice(size=own, full_length=full_length, trials=tuple(trials), within_tolerance=True,
                              tolerance=tolerance, own_pixels=True)
    connected = [t for t in trials if t.ratio is not None]
    if connected:
        best = min(connected, key=lambda t: (t.ratio, t.size))
        return SizeChoice(size=best.size, full_length=full_length, trials=tuple(trials), within_tolerance=False,
                          tolerance=tolerance, own_pixels=best.size == own > sizes[-1])
    raise NoPathError(bottleneck_message(free_check, start, goal, trials, resolution))


def narrowest_passage(free_check: np.ndarray, start: Sequence[int], goal: Sequence[int],
                      near: float = 0.0) -> tuple[tuple[int, int], float]:
    """The bottleneck between start and goal on ``free_check``: where it is and how wide, in pixels.

    The widest route's narrowest point (a maximin search): the largest clearance ``t`` such that
    start and goal connect through pixels at least ``t`` from every obstacle (pixels within ``near``
    of start or goal always count), and the least-clearance pixel of the shortest route at that
    level. Width: ``2 t - 1`` (a corridor ``w`` free pixels wide gives ``w``). Assumes start and goal
    are connected on ``free_check``.
    """
    from scipy import ndimage  # only for this diagnosis

    free = ~np.asarray(free_check, dtype=bool)
    clear = ndimage.distance_transform_edt(free)
    rows, cols = np.ogrid[: free.shape[0], : free.shape[1]]
    ends = np.zeros_like(free)
    for r, c in (start, goal):
        ends |= (rows - r) ** 2 + (cols - c) ** 2 <= near * near
    ends &= free
    levels = np.unique(clear[free])

    def connects(t: float) -> bool:
        # 4-connected components: moves that never cut a corner (the route below, the safe grid) connect
        # exactly the sets that are 4-connected; 8-connected labels would pass diagonal pinches they cannot
        labels, _ = ndimage.label((clear >= t) | ends)
        return bool(labels[tuple(start)] and labels[tuple(start)] == labels[tuple(goal)])

    lo, hi = 0, len(levels) - 1  # levels[lo] always connects (every free pixel), find the highest that does
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if connects(levels[mid]):
            lo = mid
        else:
            hi = mid - 1
    t = float(levels[lo])
    route = shortest_path8(~((clear >= t) | ends), start, goal).path
    pts = np.asarray(route, dtype=np.int64)
    along = np.where(ends[pts[:, 0], pts[:, 1]], np.inf, clear[pts[:, 0], pts[:, 1]])
    k = int(np.argmin(along))
    return (int(pts[k, 0]), int(pts[k, 1])), max(1.0, 2.0 * t - 1.0)


def _metres(px: float, resolution: float | None, what: str = "", digits: int = 0) -> str:
    return f"{px:.{digits}f} px{what}" + (f" = {px * resolution:.2g} m" if resolution is not None else "")


def size_to_open(longest: int, width_px: float) -> int:
    """Cells on the longer side at which a passage ``width_px`` pixels wide surely stays open on the safe
    grid: a whole cell fits inside it wherever the cell borders fall, i.e. cells of at most half its width."""
    return int(math.ceil(2.0 * longest / max(1.0, width_px)))


def bottleneck_message(free_check: np.ndarray, start: Sequence[int], goal: Sequence[int],
                       trials: Sequence[SizeTrial], resolution: float | None = None) -> str:
    """Why no safe grid connects start and goal: the narrowest passage on the map's own route (where, how wide
    in pixels and metres), the finest cells tried, and the size that would keep it open."""
    finest = trials[-1] if trials else None
    try:
        shortest_path8(free_check, start, goal)
    except NoPathError:
        return (f"start {tuple(start)} and goal {tuple(goal)} are not connected on the map itself "
                f"(after inflating obstacles by the robot radius)")
    (r, c), width = narrowest_passage(free_check, start, goal, near=finest.cell_px if finest else 0.0)
    where = f"the passage at pixel ({r}, {c}) is about {_metres(width, resolution)} wide"
    grids = (f"on no safe grid up to {finest.size} cells: {where} and the finest grid has "
             f"{_metres(finest.cell_px, resolution, ' cells', 1)}" if finest else f"on no safe grid: {where}")
    need = size_to_open(max(free_check.shape), width)
    what = (f"--max-size {need} --size {need} keeps it open" if need <= MAX_GRID_SIZE else
            f"a grid that keeps it open needs {need} cells, more than the limit {MAX_GRID_SIZE}: crop the map around "
            f"start and goal")
    return (f"start and goal are connected on the map but {grids}; {what} (or a smaller --robot-radius, or --grid "
            f"area, the paper's rule, which may cut through thin walls)")
