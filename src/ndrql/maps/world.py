"""World coordinates of ROS ``map_server`` maps: pixels <-> metres, poses with orientation, nav_msgs/Path.

A ``map_server`` map has a ``resolution`` (metres per pixel) and an ``origin`` ``(x, y, yaw)``: the
pose, in the ``map`` frame, of the lower-left corner of the image. Image row ``H - 1`` is the bottom
row, so pixel ``(r, c)`` (centre at ``(r, c)``, see :mod:`ndrql.maps.lines`) has map-frame
coordinates ``origin + R(yaw) @ ((c + 0.5) * res, (H - 0.5 - r) * res)``. Maps without a resolution
(plain images, ``.npy``, MovingAI) have no world frame: these functions then return ``None`` or
raise :class:`~ndrql.errors.PointError` with what to do.

A path's poses carry an orientation: each pose faces the next one (the last keeps the direction of
the final segment unless a goal yaw is given; a given start yaw replaces the first). Orientations
are yaw angles about z, written as quaternions ``(x, y, z, w) = (0, 0, sin(yaw / 2), cos(yaw / 2))``.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from ndrql.errors import PointError
from ndrql.maps.grid import GridMap

#: The frame ROS 2 navigation plans in (``header.frame_id`` of the written path).
MAP_FRAME = "map"


def has_world_frame(grid_map: GridMap) -> bool:
    """Whether the map has a resolution and an origin (a ROS ``map_server`` map)."""
    return grid_map.resolution is not None and grid_map.origin is not None


def _frame(grid_map: GridMap) -> tuple[float, float, float, float]:
    res = float(grid_map.resolution)  # type: ignore[arg-type]
    origin = tuple(grid_map.origin or ())
    yaw = float(origin[2]) if len(origin) > 2 else 0.0
    return res, float(origin[0]), float(origin[1]), yaw


def pixels_to_world(grid_map: GridMap, points: Sequence[Sequence[float]] | np.ndarray) -> np.ndarray | None:
    """Map-frame ``(x, y)`` in metres of ``(row, col)`` pixel points, shape ``(K, 2)``; ``None`` without a world frame."""
    if not has_world_frame(grid_map):
        return None
    res, x0, y0, yaw = _frame(grid_map)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    dx = (pts[:, 1] + 0.5) * res
    dy = (grid_map.height - 0.5 - pts[:, 0]) * res
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.stack([x0 + cy * dx - sy * dy, y0 + sy * dx + cy * dy], axis=1)


def world_to_pixel(grid_map: GridMap, x: float, y: float, name: str = "point") -> tuple[int, int]:
    """The pixel ``(row, col)`` whose square contains map-frame point ``(x, y)`` (metres).

    Raises :class:`PointError` for a map without a world frame or a point off the map.
    """
    if not has_world_frame(grid_map):
        raise PointError(f"{name} in world coordinates needs a map with a resolution and origin "
                         f"(a ROS map_server .yaml); give ROW,COL pixels instead")
    if not (math.isfinite(x) and math.isfinite(y)):
        raise PointError(f"{name} {x},{y} is not a finite point")
    res, x0, y0, yaw = _frame(grid_map)
    cy, sy = math.cos(yaw), math.sin(yaw)
    dx, dy = cy * (x - x0) + sy * (y - y0), -sy * (x - x0) + cy * (y - y0)
    inside = all(math.isfinite(v) and abs(v) < 1e15 for v in (dx / res, dy / res))  # 1e308 m: off, not a crash
    col = math.floor(dx / res) if inside else -1
    row = grid_map.height - 1 - math.floor(dy / res) if inside else -1
    if not (0 <= row < grid_map.height and 0 <= col < grid_map.width):
        x_lo, y_lo = x0, y0
        raise PointError(f"{name} ({x:g}, {y:g}) m is off the map (it covers {grid_map.width * res:g} x "
                         f"{grid_map.height * res:g} m from the origin ({x_lo:g}, {y_lo:g}))")
    return int(row), int(col)


def parse_world_point(text: str, name: str = "point") -> tuple[float, float, float | None]:
    """Parse ``"X,Y"`` or ``"X,Y,YAW"`` (metres, radians) into ``(x, y, yaw or None)``."""
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) not in (2, 3):
        raise PointError(f"{name} must be X,Y or X,Y,YAW (metres, radians), got {str(text)[:60]!r}")
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise PointError(f"{name} must be X,Y or X,Y,YAW (metres, radians), got {str(text)[:60]!r}") from None
    if not all(math.isfinite(v) for v in vals):
        raise PointError(f"{name} must be finite numbers, got {str(text)[:60]!r}")
    return vals[0], vals[1], (vals[2] if len(vals) == 3 else None)


def path_yaws(xy: np.ndarray, start_yaw: float | None = None, goal_yaw: float | None = None) -> np.ndarray:
    """Yaw of each pose of a path: towards the next point; the last keeps the final segment's direction.

    ``start_yaw``/``goal_yaw`` replace the first/last yaw when given. A one-point path faces 0 (or the given yaw).
    """
    pts = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    n = len(pts)
    yaws = np.zeros(n)
    if n >= 2:
        d = np.diff(pts, axis=0)
        yaws[:-1] = np.arctan2(d[:, 1], d[:, 0])
        yaws[-1] = yaws[-2]
    if n and start_yaw is not None:
        yaws[0] = float(start_yaw)
    if n and goal_yaw is not None:
        yaws[-1] = float(goal_yaw)
    return yaws


def yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """Quaternion ``(x, y, z, w)`` of a rotation by ``yaw`` about z."""
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def densify(poses: np.ndarray, spacing: float) -> np.ndarray:
    """``(x, y, yaw)`` poses with points added along each segment so that consecutive poses are at most
    ``spacing`` apart (metres), evenly spread over the segment; an added pose faces along its segment, the
    given poses keep their yaws. ``spacing <= 0`` returns the poses as they are.

    Path followers (Nav2's controllers) expect a pose about every map cell, as Nav2's planners publish;
    the learned path, shortcut by line of sight, has only its corners (a few metres apart).
    """
    pts = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    if not spacing > 0 or len(pts) < 2:
        return pts.copy()
    rows = [pts[:1]]
    for a, b in zip(pts[:-1], pts[1:]):
        dx, dy = b[0] - a[0], b[1] - a[1]
        n = max(1, int(math.ceil(math.hypot(dx, dy) / spacing - 1e-9)))
        t = np.arange(1, n + 1, dtype=np.float64)[:, None] / n
        seg = np.hstack([a[:2] + t * (b[:2] - a[:2]), np.full((n, 1), math.atan2(dy, dx))])
        seg[-1, 2] = b[2]
        rows.append(seg)
    return np.vstack(rows)


def nav_path(poses: np.ndarray, frame_id: str = MAP_FRAME, digits: int = 4, spacing: float = 0.0) -> dict[str, Any]:
    """A ``nav_msgs/msg/Path`` as plain data (header with ``frame_id``, zero stamp; one ``PoseStamped``
    per ``(x, y, yaw)`` row of ``poses``, :func:`densify`-ed to at most ``spacing`` metres apart when
    ``spacing > 0``), ready for YAML/JSON and ``ros2 topic pub``."""
    stamp = {"sec": 0, "nanosec": 0}
    out = []
    for x, y, yaw in densify(poses, spacing):
        qx, qy, qz, qw = yaw_quaternion(float(yaw))
        out.append({
            "header": {"stamp": dict(stamp), "frame_id": frame_id},
            "pose": {
                "position": {"x": round(float(x), digits), "y": round(float(y), digits), "z": 0.0},
                "orientation": {"x": qx, "y": qy, "z": round(qz, 6), "w": round(qw, 6)},
            },
        })
    return {"header": {"stamp": stamp, "frame_id": frame_id}, "poses": out}
