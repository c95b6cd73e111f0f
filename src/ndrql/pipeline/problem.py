"""From a map and two points to the planning problem: read and check them, inflate by the robot, build the grid.

Two grid rules (:data:`~ndrql.pipeline.settings.GRID_RULES`):

- ``area``, the paper's (docs/method.md): the map area-averaged to ``size x size`` cells, a cell
  blocked when at least half of it is obstacle (:class:`~ndrql.maps.grid.PlanningGrid`);
- ``safe``, the default on a user's map: square cells, a cell blocked when any pixel is an obstacle
  (:mod:`ndrql.maps.safe`), at a given size or the coarsest size that keeps the route
  (:func:`~ndrql.maps.sizing.choose_size`).

Both run on the map after inflating its obstacles by the robot's radius (:func:`~ndrql.maps.safe.inflate`);
that inflated map (``GridSetup.check_map``) is also what every learned path is checked against.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ndrql.errors import MapFormatError, NoPathError, PointError
from ndrql.limits import check_cell
from ndrql.maps.grid import GridMap, PlanningGrid, SnapWarning, planning_grid
from ndrql.maps.world import world_to_pixel
from ndrql.maps.readers import MAX_MAP_PIXELS, load_map, read_movingai_scen
from ndrql.maps.scenarios import ScenarioWarning, scenario_doubts
from ndrql.maps.safe import cell_size_px, conservative_grid, inflate, radius_to_px
from ndrql.maps import sizing  # sizing.safe_grid, read at each call: the one builder (tests count its calls)
from ndrql.maps.sizing import choose_size, connected4, full_route, ladder, try_size
from ndrql.pipeline.settings import SLOW_SIZE, PlanSettings

Point = tuple[int, int]


class SlowGridWarning(UserWarning):
    """The planning grid is large: Q-learning may take minutes."""


@dataclass(frozen=True)
class GridSetup:
    """How the map became the planning grid, and the full-resolution map paths are checked on."""

    rule: str
    """``safe`` or ``area``."""
    size: int
    """Cells on the map's longer side (area rule: the grid's side)."""
    radius_px: float
    """Robot radius in map pixels (obstacles inflated by it)."""
    check_map: np.ndarray = field(repr=False)
    """The map after inflation (``True`` = obstacle), read-only: paths are checked and shortcut on it."""
    auto: Any = None
    """The :class:`~ndrql.maps.sizing.SizeChoice` of ``size auto``, else ``None``."""
    seconds: float = 0.0
    """Wall time spent on inflation and the size search."""
    belief: Any = None
    """The planning grid of the belief map (:mod:`ndrql.pipeline.belief`: what the priors see; the learning grid is
    the true map's), on the same cells; ``None`` when the planner knows the map."""

    def to_dict(self, grid: PlanningGrid, resolution: float | None) -> dict[str, Any]:
        """JSON form: rule, size, cell size in px (and m), robot radius, and the auto search."""
        sr, sc = grid.cell_size
        out: dict[str, Any] = {"rule": self.rule, "size": self.size, "shape": list(grid.shape),
                               "cell_px": [round(sr, 4), round(sc, 4)], "robot_radius_px": round(self.radius_px, 4)}
        if resolution is not None:
            out["cell_m"] = [round(sr * resolution, 6), round(sc * resolution, 6)]
            out["robot_radius_m"] = round(self.radius_px * resolution, 6)
        if self.auto is not None:
            a = self.auto
            out["auto"] = {
                "tolerance": a.tolerance,
                "within_tolerance": a.within_tolerance,
                "full_length_px": round(a.full_length, 3),
                "tried": [{"size": t.size, "shape": list(t.shape), "cell_px": round(t.cell_px, 4),
                           "grid_length_px": None if t.grid_length is None else round(t.grid_length, 3),
                           "ratio": None if t.ratio is None else round(t.ratio, 4)} for t in a.trials],
            }
            if resolution is not None:
                out["auto"]["full_length_m"] = round(a.full_length * resolution, 4)
        return out


def read_map(map_or_path: Any, *, invert: bool = False, threshold: float = 128, crop: bool = False,
             max_pixels: int = MAX_MAP_PIXELS) -> GridMap:
    """A :class:`GridMap` from a path (any supported format; larger than ``max_pixels`` refused before it is
    decoded), a ``GridMap`` or a 2-D array (non-zero = obstacle)."""
    if isinstance(map_or_path, GridMap):
        return map_or_path
    if isinstance(map_or_path, np.ndarray):
        if map_or_path.ndim != 2 or map_or_path.size == 0:
            raise MapFormatError(f"a map array must be non-empty and 2-D, got shape {map_or_path.shape}")
        return GridMap(map_or_path != 0, source="array")
    if isinstance(map_or_path, (str, os.PathLike)):
        return load_map(map_or_path, invert=invert, threshold=threshold, crop=crop, max_pixels=max_pixels)
    raise MapFormatError(f"cannot read a map from {type(map_or_path).__name__}; pass a file path, a GridMap or a 2-D array")


def scenario_points(scen: str | os.PathLike, index: int, grid_map: GridMap) -> tuple[Point, Point, dict[str, Any]]:
    """Start and goal ``(row, col)`` of scenario ``index`` in a MovingAI ``.scen`` file, checked against the map."""
    scenarios = read_movingai_scen(scen)
    if not 0 <= index < len(scenarios):
        raise MapFormatError(f"scenario {index} not in {scen}: it has scenarios 0..{len(scenarios) - 1}"
                             if scenarios else f"{scen} has no scenarios")
    s = scenarios[index]
    if grid_map.shape != (s.height, s.width):
        raise MapFormatError(f"scenario {index} of {scen} is for a {s.width}x{s.height} map (width x height), "
                             f"the map is {grid_map.width}x{grid_map.height}")
    for doubt in scenario_doubts([s], str(grid_map.source), scen, numbers=[index]):
        warnings.warn(doubt, ScenarioWarning, stacklevel=2)
    info = {"scenario": {"file": str(scen), "index": index, "optimal_length": s.optimal_length}}
    return (int(s.start[0]), int(s.start[1])), (int(s.goal[0]), int(s.goal[1])), info


def check_points(grid_map: GridMap, start: Sequence[int], goal: Sequence[int]) -> tuple[Point, Point]:
    """``start``/``goal`` as ``(row, col)`` ints, on the map and on free pixels; :class:`PointError` otherwise."""
    h, w = grid_map.shape
    out = []
    for name, p in (("start", start), ("goal", goal)):
        if p is None:
            raise PointError(f"no {name} given (ROW,COL in map pixels)")
        try:
            r, c = check_cell(p, name)  # (0.7, 0) is not row 0
        except ValueError as exc:
            raise PointError(str(exc)) from None
        if not (0 <= r < h and 0 <= c < w):
            raise PointError(f"{name} {r},{c} is outside the map (rows 0..{h - 1}, cols 0..{w - 1})")
        if grid_map.obstacles[r, c]:
            raise PointError(f"{name} {r},{c} is on an obstacle of the map")
        out.append((r, c))
    return out[0], out[1]


def world_point(grid_map: GridMap, given: Sequence[float] | None, name: str) -> tuple[Point | None, float | None]:
    """A ``(x, y[, yaw])`` world point (metres) as a map pixel and its yaw."""
    if given is None:
        return None, None
    try:
        vals = [float(v) for v in given]
    except (TypeError, ValueError):
        raise PointError(f"{name} must be (x, y) or (x, y, yaw) in metres and radians") from None
    if len(vals) not in (2, 3):
        raise PointError(f"{name} must be (x, y) or (x, y, yaw) in metres and radians, got {len(vals)} numbers")
    r, c = world_to_pixel(grid_map, vals[0], vals[1], name)
    if grid_map.obstacles[r, c]:  # said in the units it was given in; a ROS map's unknown space is an obstacle
        raise PointError(f"{name} ({vals[0]:g}, {vals[1]:g}) m is on an obstacle or in unknown space of the map "
                         f"(pixel {r},{c}); give a point in known free space")
    return (r, c), (vals[2] if len(vals) == 3 else None)


def place_points(grid_map: GridMap, start: Sequence[int] | None, goal: Sequence[int] | None, *,
                 scen: str | os.PathLike | None = None, scen_index: int = 0, start_world: Sequence[float] | None = None,
                 goal_world: Sequence[float] | None = None,
                 info: dict[str, Any] | None = None) -> tuple[Point, Point, float | None, float | None]:
    """Start and goal in checked map pixels, and their yaws, from pixels, world points or MovingAI scenario
    ``scen_index`` of ``scen`` (pixels given win over the scenario's; a point in pixels and in metres is an
    error). The scenario's record goes into ``info``."""
    if scen is not None:
        s_start, s_goal, s_info = scenario_points(scen, scen_index, grid_map)
        start = start if start is not None else s_start
        goal = goal if goal is not None else s_goal
        if info is not None:
            info.update(s_info)
    w_start, start_yaw = world_point(grid_map, start_world, "start")
    w_goal, goal_yaw = world_point(grid_map, goal_world, "goal")
    for name, px, w in (("start", start, w_start), ("goal", goal, w_goal)):
        if px is not None and w is not None:
            raise PointError(f"give the {name} in pixels or in world coordinates, not both")
    start = w_start if w_start is not None else start
    goal = w_goal if w_goal is not None else goal
    s, g = check_points(grid_map, start, goal)  # type: ignore[arg-type]
    return s, g, start_yaw, goal_yaw


def check_map_size(grid_map: GridMap, settings: PlanSettings) -> None:
    """Refuse maps larger than ``settings.max_map_pixels`` (they cost memory and time for nothing)."""
    if grid_map.height * grid_map.width > settings.max_map_pixels:
        raise MapFormatError(
            f"map is {grid_map.height}x{grid_map.width} = {grid_map.height * grid_map.width:,} pixels, more than the "
            f"limit of {settings.max_map_pixels:,}; crop or downscale it, or raise --max-pixels"
        )


def _units(px: float, resolution: float | None) -> str:
    return f"{px:.1f} px" + (f" = {px * resolution:.3g} m" if resolution is not None else "")


def check_clearance(check_map: np.ndarray, grid_map: GridMap, points: Sequence[Point], radius_px: float) -> None:
    """Refuse a start or goal within the robot radius of an obstacle (:class:`PointError`)."""
    for name, (r, c) in zip(("start", "goal"), points):
        if check_map[r, c]:
            raise PointError(f"{name} {r},{c} is within the robot radius ({_units(radius_px, grid_map.resolution)}) "
                             f"of an obstacle; move it into the open or use a smaller --robot-radius")


def _area_grid(check_map: np.ndarray, start: Point, goal: Point, size: int) -> PlanningGrid:
    """The paper's grid; its errors get a hint about the safe grid."""
    try:
        return PlanningGrid.from_map(check_map, start, goal, size=size)
    except NoPathError as exc:
        raise NoPathError(f"{exc}; the safe grid keeps thin passages: --grid safe --size auto") from None


def _suggest_size(check_map: np.ndarray, start: Point, goal: Point, size: int, max_size: int) -> int | None:
    for s in ladder(check_map.shape, max_size):
        if s > size and try_size(check_map, start, goal, s, 1.0).grid_length is not None:
            return s
    return None


def _safe_grid(check_map: np.ndarray, grid_map: GridMap, start: Point, goal: Point, size: int,
               max_size: int) -> PlanningGrid:
    pg = sizing.safe_grid(check_map, size, start, goal)
    blocked, cells = pg.blocked, (pg.start, pg.goal)
    for name, p, cell, moved in zip(("start", "goal"), (start, goal), cells, pg.snapped):
        if moved:  # in map pixels, as the point was given: the free cell by the pixel at its centre
            cr, cc = pg.centre(cell)
            warnings.warn(f"{name} {p[0]},{p[1]}: its cell of the safe grid touches an obstacle; planning from the "
                          f"nearest free cell, centred at pixel {cr:.0f},{cc:.0f} (joined to the point on the full map)",
                          SnapWarning, stacklevel=3)
    s = cell_size_px(check_map.shape, size)
    if cells[0] != cells[1] and not connected4(blocked, cells[0], cells[1]):
        better = _suggest_size(check_map, start, goal, size, max_size)
        hint = (f"--size {better} connects them (or --size auto)" if better is not None
                else "no finer grid up to the limit does either; try --size auto for where the bottleneck is")
        raise NoPathError(f"start and goal are not connected on the {blocked.shape[0]}x{blocked.shape[1]} safe grid "
                          f"({_units(s, grid_map.resolution)} cells; a passage narrower than a cell closes): {hint}")
    return pg


def inflated(grid_map: GridMap, settings: PlanSettings) -> tuple[np.ndarray, float]:
    """The map's obstacles inflated by the robot's radius (read-only), and that radius in pixels."""
    radius_px = radius_to_px(settings.robot_radius, grid_map.resolution)
    check_map = inflate(grid_map.obstacles, radius_px) if radius_px >= 1 else np.array(grid_map.obstacles, dtype=bool)
    check_map.setflags(write=False)
    return check_map, radius_px


def map_grid(grid_map: GridMap, settings: PlanSettings) -> tuple[np.ndarray, str]:
    """The blocked cells of the whole map under ``settings`` when no route is given (``size`` an integer),
    and a line naming the grid: what ``map info`` shows without start and goal."""
    check_map, radius_px = inflated(grid_map, settings)
    size = int(settings.grid_size)
    if settings.grid == "area":
        blocked = planning_grid(check_map, size)
        rule = "area (the paper's: area-averaged, blocked at >= half obstacle)"
        cell = f"{grid_map.height / blocked.shape[0]:.2f}x{grid_map.width / blocked.shape[1]:.2f} px"
    else:
        blocked = conservative_grid(check_map, size)
        rule = "safe (square cells, a cell blocked when any pixel is an obstacle)"
        cell = _units(cell_size_px(check_map.shape, size), grid_map.resolution)
    radius = f", robot radius {_units(radius_px, grid_map.resolution)}" if radius_px > 0 else ""
    return blocked, (f"planning grid: {rule}, {blocked.shape[0]}x{blocked.shape[1]} cells of {cell} "
                     f"(size {size}{radius})")


def build_grid(grid_map: GridMap, start: Point, goal: Point, settings: PlanSettings) -> tuple[PlanningGrid, GridSetup]:
    """The planning grid for ``start``/``goal`` (checked map pixels) under ``settings``, and how it was made.

    Raises :class:`PointError` when a point lies within the robot radius of an obstacle and
    :class:`NoPathError` (saying what to do) when no grid connects start and goal.
    """
    import time

    t0 = time.perf_counter()
    check_map, radius_px = inflated(grid_map, settings)
    check_clearance(check_map, grid_map, (start, goal), radius_px)
    size = settings.grid_size
    auto = None
    if settings.grid == "area":
        pg = _area_grid(check_map, start, goal, int(size))
    else:
        if size == "auto":
            route = full_route(check_map, start, goal, radius_px)
            auto = choose_size(check_map, start, goal, route.cost, settings.max_size, settings.tolerance,
                               grid_map.resolution)
            size = auto.size
            if auto.own_pixels:
                warnings.warn(f"no safe grid up to {settings.max_size} cells keeps start and goal connected within "
                              f"{settings.tolerance:.0%} of the map's own route; planning on the map's own pixels "
                              f"({size} cells on the longer side)", UserWarning, stacklevel=2)
            elif not auto.within_tolerance:
                t = auto.chosen
                warnings.warn(f"no safe grid up to {settings.max_size} cells keeps the route within "
                              f"{settings.tolerance:.0%} of the map's own ({_units(auto.full_length, grid_map.resolution)}); "
                              f"using the closest, {t.size} cells ({t.ratio:.2f}x)", UserWarning, stacklevel=2)
        pg = _safe_grid(check_map, grid_map, start, goal, int(size), settings.max_size)
    if max(pg.shape) > SLOW_SIZE:
        warnings.warn(f"the planning grid is {pg.shape[0]}x{pg.shape[1]}: Q-learning may take minutes "
                      f"(crop the map around start and goal for a smaller grid)", SlowGridWarning, stacklevel=2)
    return pg, GridSetup(rule=settings.grid, size=int(size), radius_px=radius_px, check_map=check_map, auto=auto,
                         seconds=time.perf_counter() - t0)


def grid_text(setup: GridSetup, grid: PlanningGrid, resolution: float | None = None) -> str:
    """One line naming the grid a command used: rule, shape, cell size, size (auto or given), robot radius."""
    sr, sc = grid.cell_size
    cell = (f"{sr:.2f}" if abs(sr - sc) < 1e-9 else f"{sr:.2f}x{sc:.2f}") + " px" + \
        (f" = {sr * resolution:.3g} m" if resolution is not None and abs(sr - sc) < 1e-9 else "")
    how = "size auto" if setup.auto is not None else f"size {setup.size}"
    rule = ("safe (square cells, a cell blocked when any pixel is an obstacle)" if setup.rule == "safe"
            else "area (the paper's: area-averaged, blocked at >= half obstacle)")
    radius = f", robot radius {_units(setup.radius_px, resolution)}" if setup.radius_px > 0 else ""
    return f"planning grid: {rule}, {grid.shape[0]}x{grid.shape[1]} cells of {cell} ({how}{radius})"
