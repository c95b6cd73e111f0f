"""The path-planning dataset's label definition, at any scale: guideline and region of a path.

The dataset labels each sample with the planner's path drawn two ways:

- the **guideline** (``PATH [2PIXEL]``): the straight-segment polyline through the path's
  waypoints, drawn as OpenCV draws ``cv2.line(img, (col0, row0), (col1, row1), 255, thickness=2)``
  for each consecutive pair (:func:`draw_guideline`, rasterised by :mod:`ndrql.maps.raster`);
- the **region** (``PATH [30PIXEL]``): the square dilation of the guideline by a 30x30 window, 15
  px before and 14 px after each pixel (``cv2.dilate(guideline, ones((30, 30)))``,
  :func:`dilate_region`).

The dataset's paths come from RRT*; ours come from :func:`near_optimal_path`: the shortest
8-connected path without corner cutting (:func:`ndrql.maps.astar.shortest_path8`) followed by
greedy line-of-sight shortcutting (:func:`ndrql.maps.lines.shortcut`), so every segment of the
polyline is collision-free. :func:`make_labels` puts the three together.

The sizes are the dataset's at 201 px of map (about 4 px per cell of the 50x50 planning grid);
scale them with the map for other sizes. The functions that search or draw import their numba
kernels on first use, so importing this module stays cheap (the dataset reader imports
:func:`dilate_region` from here).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ndrql.maps.astar import shortest_path8_cells

#: Guideline width of the dataset's labels (``cv2.line`` thickness), in pixels.
GUIDE_PX = 2
#: Region window of the dataset's labels (``cv2.dilate`` with ``ones((30, 30))``), in pixels.
REGION_PX = 30


@dataclass(frozen=True)
class Labels:
    """A path and its two label images, all at the map's resolution."""

    waypoints: np.ndarray
    """``(K, 2)`` int ``(row, col)`` polyline vertices, from start to goal."""
    guideline: np.ndarray
    """bool, the polyline drawn :data:`GUIDE_PX` wide (the dataset's ``PATH [2PIXEL]``)."""
    region: np.ndarray
    """bool, the guideline dilated by a :data:`REGION_PX` square (the dataset's ``PATH [30PIXEL]``)."""


def near_optimal_path(obstacles: np.ndarray, start: Sequence[int], goal: Sequence[int]) -> np.ndarray:
    """``(K, 2)`` int waypoints from ``start`` to ``goal``: shortest 8-connected path, then shortcut.

    The octile-optimal path without corner cutting is shortened by greedy farthest-visible
    shortcutting, so the polyline is no longer than the grid path and every segment's supercover
    is free. Raises :class:`~ndrql.errors.PointError` for a point off the map or on an obstacle and
    :class:`~ndrql.errors.NoPathError` when the two are not connected.
    """
    from ndrql.maps.lines import shortcut  # lazy: loads numba

    obstacles = np.asarray(obstacles, dtype=bool)
    return shortcut(obstacles, shortest_path8_cells(obstacles, start, goal))


def draw_guideline(shape: Sequence[int], waypoints: np.ndarray, thickness: int = GUIDE_PX) -> np.ndarray:
    """The polyline through ``waypoints`` (``(row, col)``) drawn ``thickness`` wide, as a bool image.

    Each consecutive pair is drawn like ``cv2.line(img, (col0, row0), (col1, row1), 255, thickness)``
    (``LINE_8``); a single waypoint gives its end cap. Float waypoints are drawn at sub-pixel
    positions (as OpenCV's ``shift`` argument would).
    """
    from ndrql.maps.raster import draw_polyline  # lazy: loads numba

    return draw_polyline((int(shape[0]), int(shape[1])), np.asarray(waypoints).reshape(-1, 2), thickness)


def dilate_region(guideline: np.ndarray, size: int = REGION_PX) -> np.ndarray:
    """Square dilation of ``guideline`` by a ``size`` x ``size`` window, as a bool image.

    Pixel ``(r, c)`` is set when a guideline pixel lies in rows ``r - size // 2 .. r + size - 1 -
    size // 2`` and the same columns: ``cv2.dilate(guideline, ones((size, size)))`` semantics (15 px
    before and 14 after for the dataset's 30). Exact on the dataset's own labels.
    """
    from scipy.ndimage import maximum_filter

    if int(size) < 1:
        raise ValueError(f"region size must be >= 1, got {size}")
    # scipy centres a window of ``size`` at offset ``size // 2``: it spans [i - size//2, i + size - 1 - size//2].
    return maximum_filter(np.asarray(guideline).astype(np.uint8), size=int(size), mode="constant", cval=0) > 0


def make_labels(obstacles: np.ndarray, start: Sequence[int], goal: Sequence[int]) -> Labels:
    """The dataset's labels for ``start -> goal`` on ``obstacles``, from our near-optimal path."""
    obstacles = np.asarray(obstacles, dtype=bool)
    waypoints = near_optimal_path(obstacles, start, goal)
    guideline = draw_guideline(obstacles.shape, waypoints)
    return Labels(waypoints=waypoints, guideline=guideline, region=dilate_region(guideline))
