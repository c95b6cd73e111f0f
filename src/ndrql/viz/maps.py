"""Plots of maps, planning grids and paths. Every function draws on a given ``ax`` and returns its
artists; none calls ``show`` or touches the global backend (use :func:`new_figure` + ``savefig``).
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ndrql.maps.grid import cell_to_point
from ndrql.viz.style import (ASTAR_COLOR, BLOCKED_ALPHA, BLOCKED_COLOR, GOAL_COLOR, OBSTACLE_COLOR, START_COLOR,
                             legend_below)


def new_figure(figsize: tuple[float, float] = (6.0, 6.0), dpi: int = 100) -> Any:
    """A matplotlib ``Figure`` bound to the Agg canvas, independent of pyplot and its backend."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def figure_or_new(fig: Any, figsize: tuple[float, float], dpi: int = 100, layout: str | None = None) -> Any:
    """The figure a builder draws on: ``fig`` as the caller gave it (its size and layout are the caller's),
    else a :func:`new_figure` of ``figsize`` and ``dpi`` with the layout engine ``layout`` (e.g. ``"constrained"``)."""
    if fig is not None:
        return fig
    fig = new_figure(figsize=figsize, dpi=dpi)
    if layout is not None:
        fig.set_layout_engine(layout)
    return fig


def frame_map(ax: Any, shape: tuple[int, int]) -> None:
    """Fit ``ax`` to a map or grid of ``shape`` (row 0 on top, pixel centres on integers), equal aspect, no ticks."""
    h, w = shape
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])


def plot_occupancy(ax: Any, obstacles: np.ndarray, *, alpha: float = 1.0, color: str = "black",
                   extent: Sequence[float] | None = None, zorder: int = 0) -> Any:
    """Draw obstacles in ``color`` on a transparent background; returns the ``AxesImage``.

    Pixel ``(row, col)`` is centred at ``x = col``, ``y = row`` (row 0 on top) unless ``extent`` says otherwise.
    """
    from matplotlib.colors import ListedColormap

    obstacles = np.asarray(obstacles, dtype=bool)
    h, w = obstacles.shape
    cmap = ListedColormap([(1, 1, 1, 0), color])
    if extent is None:
        extent = (-0.5, w - 0.5, h - 0.5, -0.5)
    return ax.imshow(obstacles.astype(np.uint8), cmap=cmap, vmin=0, vmax=1, alpha=alpha,
                     interpolation="nearest", extent=extent, zorder=zorder)


def plot_path(ax: Any, path: Sequence[Sequence[float]], *, color: str = "tab:red", linewidth: float = 2.0,
              label: str | None = "path", zorder: int = 3) -> list[Any]:
    """Draw a path given as ``(row, col)`` points (in the axes' pixel frame); returns the line."""
    pts = np.asarray(path, dtype=float).reshape(-1, 2)
    return ax.plot(pts[:, 1], pts[:, 0], "-", color=color, linewidth=linewidth, label=label, zorder=zorder)


def plot_endpoints(ax: Any, start: Sequence[float], goal: Sequence[float], *, size: float = 80) -> list[Any]:
    """Mark start (green circle) and goal (blue star), points as ``(row, col)``; returns both artists."""
    s = ax.scatter([start[1]], [start[0]], s=size, c=START_COLOR, marker="o", edgecolors="white", label="start", zorder=4)
    g = ax.scatter([goal[1]], [goal[0]], s=size * 1.6, c=GOAL_COLOR, marker="*", edgecolors="white", label="goal", zorder=4)
    return [s, g]


def plot_planning_result(ax: Any, obstacles: np.ndarray, blocked: np.ndarray, path_cells: Sequence[Sequence[int]],
                         source_start: Sequence[int], source_goal: Sequence[int], *, title: str | None = None,
                         cell_size: tuple[float, float] | None = None,
                         path_points: Sequence[Sequence[float]] | None = None) -> list[Any]:
    """The source map, the planning grid's blocked cells (shaded) and the A* path on the planning grid, in source
    pixels, in the style of ``plan``'s figures (:mod:`ndrql.viz.style`: A* blue and dashed, legend below the map).

    Cell centres are converted with :func:`ndrql.maps.grid.cell_to_point` (the area grid), or drawn as
    ``path_points`` (map pixels) when given; ``cell_size``: square cells of that many pixels (the safe
    grid, which may reach past the map). Returns every artist drawn.
    """
    from matplotlib.patches import Patch

    obstacles = np.asarray(obstacles, dtype=bool)
    h, w = obstacles.shape
    artists: list[Any] = []
    artists.append(plot_occupancy(ax, obstacles, color=OBSTACLE_COLOR, zorder=1))
    sr, sc = cell_size if cell_size is not None else (h / blocked.shape[0], w / blocked.shape[1])
    artists.append(plot_occupancy(ax, blocked, color=BLOCKED_COLOR, alpha=BLOCKED_ALPHA,
                                  extent=(-0.5, blocked.shape[1] * sc - 0.5, blocked.shape[0] * sr - 0.5, -0.5), zorder=2))
    pts = path_points if path_points is not None else [cell_to_point(c, (h, w), blocked.shape) for c in path_cells]
    artists += plot_path(ax, pts, color=ASTAR_COLOR, linewidth=2.0, label=f"A* ({len(path_cells) - 1} moves)")
    artists[-1].set_linestyle("--")
    artists += plot_endpoints(ax, source_start, source_goal)
    frame_map(ax, (h, w))
    if title:
        artists.append(ax.set_title(title, fontsize=9))
    handles, _ = ax.get_legend_handles_labels()
    handles += [Patch(color=OBSTACLE_COLOR, label="obstacle"),
                Patch(color=BLOCKED_COLOR, alpha=BLOCKED_ALPHA, label="blocked cell")]
    artists.append(legend_below(ax, handles))
    return artists
