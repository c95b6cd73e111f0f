"""A learned grid path on the full-resolution map: polyline, collision check, shortcut, world poses.

Q-learning returns a path of planning cells. :func:`make_route` turns it into what a robot drives:

1. the **grid polyline** in map pixels: the start pixel, the centres of the path's cells, the goal
   pixel. The first and last legs (point to its cell's centre) are straight when that line is free,
   else the shortest 8-connected path on the full map (a point whose cell touches an obstacle
   was planned from a neighbouring cell);
2. the **check**: every segment of it against the full-resolution map after inflation by the robot
   radius (:func:`~ndrql.maps.lines.polyline_collisions`, conservative supercover line of sight);
3. the **final path**: with smoothing, greedy line-of-sight shortcutting of the polyline on the same
   map (:func:`~ndrql.maps.lines.shortcut`), which never adds a collision; without, the polyline;
4. for maps with a world frame, the final path as poses ``(x, y, yaw)`` in metres
   (:mod:`ndrql.maps.world`).

A run is a **success** when it converged and its final path has no collision: a path that crosses
an obstacle is reported (summary line, JSON ``collisions``, red marks in the figure) and never
called a success.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ndrql.errors import NoPathError
from ndrql.maps.astar import shortest_path8
from ndrql.maps.grid import GridMap, PlanningGrid
from ndrql.maps.lines import polyline_collisions, polyline_length, segment_free, shortcut
from ndrql.maps.world import path_yaws, pixels_to_world

#: Pixels around the two points of an end leg searched for a full-map path (the whole map if that fails).
LEG_MARGIN = 64


@dataclass(frozen=True)
class Route:
    """A grid path on the full map (pixels are ``(row, col)`` floats; pixel ``(r, c)``'s centre is ``(r, c)``)."""

    grid_pixels: np.ndarray
    """The grid polyline ``(K, 2)``: start pixel, cell centres (with end legs), goal pixel."""
    collisions: tuple[tuple[int, tuple[int, int]], ...]
    """Segments of the grid polyline that cross an obstacle of the inflated map: ``(segment, first blocked pixel)``."""
    pixels: np.ndarray
    """The final path ``(M, 2)``: the shortcut polyline with smoothing, else the grid polyline."""
    final_collisions: tuple[tuple[int, tuple[int, int]], ...]
    """Collisions of the final path (empty unless the grid polyline had some that could not be cut out)."""
    smoothed: bool
    """Whether the final path is the shortcut one."""
    grid_length: float
    """Length of the grid polyline in pixels."""
    length: float
    """Length of the final path in pixels."""
    poses: np.ndarray | None
    """The final path as ``(M, 3)`` map-frame poses ``x, y, yaw`` (metres, radians); ``None`` without a world frame."""
    resolution: float | None
    """Metres per pixel, ``None`` without a world frame."""

    @property
    def collides(self) -> bool:
        """Whether the final path crosses an obstacle."""
        return bool(self.final_collisions)

    def to_dict(self, grid_map: GridMap, digits: int = 3) -> dict[str, Any]:
        """JSON form: lengths in px (and m), collisions with their pixels (and world points), the paths."""
        def pts(a: np.ndarray) -> list[list[float]]:
            return [[round(float(r), digits), round(float(c), digits)] for r, c in a]

        def hits(cs: Sequence[tuple[int, tuple[int, int]]]) -> list[dict[str, Any]]:
            out = []
            for seg, (r, c) in cs:
                d: dict[str, Any] = {"segment": int(seg), "pixel": [int(r), int(c)]}
                w = pixels_to_world(grid_map, [(r, c)])
                if w is not None:
                    d["world"] = [round(float(w[0, 0]), 4), round(float(w[0, 1]), 4)]
                out.append(d)
            return out

        out: dict[str, Any] = {
            "smoothed": self.smoothed,
            "length_px": {"grid": round(self.grid_length, 3), "final": round(self.length, 3)},
            "collisions": hits(self.collisions),
            "final_collisions": hits(self.final_collisions),
            "grid_pixels": pts(self.grid_pixels),
            "pixels": pts(self.pixels),
        }
        if self.resolution is not None:
            out["length_m"] = {"grid": round(self.grid_length * self.resolution, 4),
                               "final": round(self.length * self.resolution, 4)}
        if self.poses is not None:
            out["poses"] = [[round(float(x), 4), round(float(y), 4), round(float(t), 4)] for x, y, t in self.poses]
        return out


def _leg(check_map: np.ndarray, a: Sequence[float], b: Sequence[float]) -> list[tuple[float, float]]:
    """Points from ``a`` to ``b`` (``b`` included, ``a`` not): straight when free, else the full map's shortest path."""
    b = (float(b[0]), float(b[1]))
    if segment_free(check_map, a, b):
        return [b]
    h, w = check_map.shape
    pa = (int(round(a[0])), int(round(a[1])))
    pb = (min(h - 1, max(0, int(round(b[0])))), min(w - 1, max(0, int(round(b[1])))))
    if check_map[pa] or check_map[pb]:
        return [b]
    r0, c0 = max(0, min(pa[0], pb[0]) - LEG_MARGIN), max(0, min(pa[1], pb[1]) - LEG_MARGIN)
    r1, c1 = min(h, max(pa[0], pb[0]) + LEG_MARGIN + 1), min(w, max(pa[1], pb[1]) + LEG_MARGIN + 1)
    for (y0, x0, y1, x1) in ((r0, c0, r1, c1), (0, 0, h, w)):
        try:
            res = shortest_path8(check_map[y0:y1, x0:x1], (pa[0] - y0, pa[1] - x0), (pb[0] - y0, pb[1] - x0))
        except NoPathError:
            continue
        pts = [(float(r + y0), float(c + x0)) for r, c in res.path[1:]]
        if pts and pts[-1] != b:
            pts.append(b)
        return pts or [b]
    return [b]


def grid_polyline(check_map: np.ndarray, grid: PlanningGrid, cells: Sequence[Sequence[int]]) -> np.ndarray:
    """Start pixel, centres of ``cells``, goal pixel, as a ``(K, 2)`` float array (end legs as in the module docstring)."""
    centres = [grid.centre(c) for c in cells]
    start = (float(grid.source_start[0]), float(grid.source_start[1]))
    goal = (float(grid.source_goal[0]), float(grid.source_goal[1]))
    pts: list[tuple[float, float]] = [start]
    pts += _leg(check_map, start, centres[0])
    pts += centres[1:]
    pts += _leg(check_map, centres[-1], goal)
    out = [pts[0]]
    for p in pts[1:]:
        if p != out[-1]:
            out.append(p)
    return np.asarray(out, dtype=np.float64)


def make_route(check_map: np.ndarray, grid: PlanningGrid, cells: Sequence[Sequence[int]], grid_map: GridMap, *,
               smooth: bool, start_yaw: float | None = None, goal_yaw: float | None = None) -> Route:
    """The route of a learned path ``cells`` (planning-grid cells from start to goal), checked on ``check_map``."""
    poly = grid_polyline(check_map, grid, cells)
    hits = tuple(polyline_collisions(check_map, poly))
    final = shortcut(check_map, poly) if smooth else poly
    final_hits = tuple(polyline_collisions(check_map, final)) if smooth else hits
    xy = pixels_to_world(grid_map, final)
    poses = None if xy is None else np.column_stack([xy, path_yaws(xy, start_yaw, goal_yaw)])
    return Route(grid_pixels=poly, collisions=hits, pixels=np.asarray(final, dtype=np.float64), final_collisions=final_hits,
                 smoothed=bool(smooth), grid_length=polyline_length(poly), length=polyline_length(final), poses=poses,
                 resolution=None if xy is None else float(grid_map.resolution))  # type: ignore[arg-type]


def octile_cost(points: Sequence[Sequence[float]] | np.ndarray) -> float:
    """Octile cost of a polyline: each segment costs ``max(|dr|, |dc|) + (sqrt 2 - 1) min(|dr|, |dc|)``,
    the MovingAI measure, comparable to a ``.scen`` optimal length."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(pts) < 2:
        return 0.0
    d = np.abs(np.diff(pts, axis=0))
    return float((d.max(1) + (np.sqrt(2.0) - 1.0) * d.min(1)).sum())
