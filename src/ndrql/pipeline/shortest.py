"""A* as a planner in its own right: the request :func:`~ndrql.pipeline.request.build_request` makes for
``plan``, searched with A* instead of learned, returned as an :class:`AStarRun` (the same family as
:class:`~ndrql.pipeline.report.PlannedRun`: ``method``, ``path``, ``path_length``, ``route``, ``success``,
``path_pixels``, ``poses``, ``collisions``).

Two searches:

- ``A*`` (default): 4-connected unit moves on the planning grid ``plan`` builds for the request (safe
  grid with ``size auto`` on a map file, the paper's 50x50 area grid on a dataset sample); the path's
  cells become a route on the full map exactly as a learned path does (:func:`~ndrql.pipeline.route.make_route`:
  checked for collisions, shortcut when the request smooths, world poses on ROS maps);
- ``A*-octile``: 8-connected octile moves without corner cutting on the full-resolution map after
  inflating it by the robot's radius (the MovingAI measure: its cost is comparable to a ``.scen``
  optimal length); the route is the pixel path itself, reduced to its corners.

No Q-learning runs, so the planning grid's "Q-learning may take minutes" warning is not given.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from typing import Any, Protocol, Sequence, runtime_checkable

import numpy as np

from ndrql.maps.astar import astar4, astar8
from ndrql.maps.grid import PlanningGrid
from ndrql.maps.lines import polyline_length
from ndrql.maps.world import path_yaws, pixels_to_world
from ndrql.pipeline.problem import GridSetup, SlowGridWarning, build_grid, check_clearance, inflated
from ndrql.pipeline.request import PlanRequest
from ndrql.pipeline.route import Route, make_route

#: The two searches by name (:attr:`AStarRun.method`).
ASTAR_METHODS: tuple[str, ...] = ("A*", "A*-octile")
#: Stages an A* plan spends time in, in order (``map``: reading the map and placing the points).
ASTAR_STAGES: tuple[str, ...] = ("map", "grid", "search", "route")


@runtime_checkable
class PathRun(Protocol):
    """What a plan's run and an A* run share, so either serves where a path is used (``--path-out``'s writer,
    a scenario batch's record): :class:`AStarRun` and :class:`~ndrql.pipeline.report.PlannedRun` both are one."""

    method: str
    path: Any
    path_length: Any
    route: Any

    @property
    def converged(self) -> bool: ...

    @property
    def success(self) -> bool: ...

    @property
    def path_pixels(self) -> Any: ...

    @property
    def poses(self) -> Any: ...

    @property
    def collisions(self) -> list: ...


@dataclass(frozen=True)
class AStarRun:
    """One A* search on a request's map and points, with its path on the map (module docstring)."""

    method: str
    """``A*`` (4-connected on the planning grid) or ``A*-octile`` (8-connected on the full map)."""
    path: list[list[int]]
    """Cells from start to goal ``[[row, col], ...]``: planning-grid cells (``A*``) or map pixels (``A*-octile``)."""
    path_length: float
    """Moves (``A*``) or octile cost in pixels (``A*-octile``) of :attr:`path`."""
    expanded: int
    """Nodes the search expanded."""
    route: Route = field(repr=False)
    """The path on the full map: checked, shortcut when the request smooths (``A*``), world poses on ROS maps."""
    request: PlanRequest = field(repr=False)
    """The request searched (map, points, settings)."""
    grid: PlanningGrid | None = field(default=None, repr=False)
    """The planning grid (``A*``); ``None`` for ``A*-octile``."""
    setup: GridSetup | None = field(default=None, repr=False)
    """How the map became the planning grid (``A*``); ``None`` for ``A*-octile``."""
    radius_px: float = 0.0
    """The robot radius in map pixels the obstacles were inflated by."""
    timings: dict[str, float] = field(default_factory=dict, compare=False)
    """Wall seconds per stage of :data:`ASTAR_STAGES`."""

    @property
    def converged(self) -> bool:
        """Always ``True``: a search that returns found its path (no path raises :class:`~ndrql.errors.NoPathError`)."""
        return True

    @property
    def connectivity(self) -> int:
        """4 (``A*``) or 8 (``A*-octile``)."""
        return 8 if self.method == "A*-octile" else 4

    @property
    def success(self) -> bool:
        """The final path crosses no obstacle of the (inflated) map (as :attr:`PlannedRun.success`)."""
        return not self.route.collides

    @property
    def path_pixels(self) -> np.ndarray:
        """The final path in map pixels ``(M, 2)`` (``(row, col)``)."""
        return self.route.pixels

    @property
    def poses(self) -> np.ndarray | None:
        """The final path as map-frame poses ``(M, 3)``: x, y in metres, yaw in radians (ROS maps only)."""
        return self.route.poses

    @property
    def collisions(self) -> list[tuple[int, tuple[int, int]]]:
        """Segments of the final path that cross an obstacle: ``(segment, first blocked pixel)``."""
        return list(self.route.final_collisions)

    def to_dict(self) -> dict[str, Any]:
        """JSON form: method, lengths, expansions, the route, the timings (the map and grid are the caller's)."""
        return {"method": self.method, "connectivity": self.connectivity, "path_length": self.path_length,
                "expanded": self.expanded, "success": self.success, "path": [list(c) for c in self.path],
                "route": self.route.to_dict(self.request.grid_map),
                "timings": {k: round(v, 6) for k, v in self.timings.items()}}


def corners(path: Sequence[Sequence[int]]) -> np.ndarray:
    """The points of a cell path where its direction changes (first and last kept), ``(M, 2)`` float."""
    pts = np.asarray(path, dtype=np.float64).reshape(-1, 2)
    if len(pts) <= 2:
        return pts
    d = np.diff(pts, axis=0)
    turn = np.any(d[1:] != d[:-1], axis=1)
    return np.vstack([pts[:1], pts[1:-1][turn], pts[-1:]])


def _pixel_route(request: PlanRequest, pixels: np.ndarray) -> Route:
    """A collision-free pixel polyline as a :class:`Route` (poses on maps with a world frame)."""
    grid_map = request.grid_map
    xy = pixels_to_world(grid_map, pixels)
    poses = None if xy is None else np.column_stack([xy, path_yaws(xy, request.start_yaw, request.goal_yaw)])
    length = polyline_length(pixels)
    return Route(grid_pixels=pixels, collisions=(), pixels=pixels, final_collisions=(), smoothed=False,
                 grid_length=length, length=length, poses=poses,
                 resolution=None if xy is None else float(grid_map.resolution))  # type: ignore[arg-type]


def search(request: PlanRequest, octile: bool = False) -> AStarRun:
    """A* on ``request``'s map and points (module docstring); raises :class:`~ndrql.errors.NdrqlError`
    subclasses (a point within the robot radius of an obstacle, no path) with one-line messages."""
    t: dict[str, float] = {"map": request.map_seconds}
    t0 = time.perf_counter()
    if octile:
        check_map, radius_px = inflated(request.grid_map, request.settings)
        check_clearance(check_map, request.grid_map, (request.start, request.goal), radius_px)
        t["grid"], t1 = time.perf_counter() - t0, time.perf_counter()
        res = astar8(check_map, request.start, request.goal)
        t["search"], t2 = time.perf_counter() - t1, time.perf_counter()
        route = _pixel_route(request, corners(res.path))
        t["route"] = time.perf_counter() - t2
        return AStarRun("A*-octile", [list(c) for c in res.path], float(res.cost), res.expanded, route, request,
                        radius_px=radius_px, timings=t)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SlowGridWarning)  # about Q-learning's time; A* does not learn
        pg, setup = build_grid(request.grid_map, request.start, request.goal, request.settings)
    t["grid"], t1 = time.perf_counter() - t0, time.perf_counter()
    res = astar4(pg.blocked, pg.start, pg.goal)
    t["search"], t2 = time.perf_counter() - t1, time.perf_counter()
    route = make_route(setup.check_map, pg, res.path, request.grid_map, smooth=request.settings.smoothing,
                       start_yaw=request.start_yaw, goal_yaw=request.goal_yaw)
    t["route"] = time.perf_counter() - t2
    return AStarRun("A*", [list(c) for c in res.path], float(res.moves), res.expanded, route, request, grid=pg,
                    setup=setup, radius_px=setup.radius_px, timings=t)


__all__ = ["ASTAR_METHODS", "ASTAR_STAGES", "AStarRun", "PathRun", "corners", "search"]
