"""Region and guideline predictions over the map (paper Figs. 4 and 5), and each method's path on
the same planning grid (paper Fig. 6, row 3). Functions draw on ``ax``, return artists, never ``show``."""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from ndrql.viz.maps import frame_map, plot_endpoints, plot_occupancy

from ndrql.viz.style import METHOD_COLORS  # noqa: F401  (re-exported: one home, ndrql.viz.style)


def plot_prediction(ax: Any, obstacles: np.ndarray, region: np.ndarray | None, guideline: np.ndarray | None,
                    start: Sequence[float] | None = None, goal: Sequence[float] | None = None, *,
                    threshold: float | None = None) -> list[Any]:
    """The map with the region (green) and guideline (red) probabilities laid over it.

    With ``threshold`` the predictions are drawn as masks (``p >= threshold``), else as
    transparency proportional to the probability. All arrays share one shape (map pixels or cells).
    """
    obstacles = np.asarray(obstacles, bool)
    artists: list[Any] = [plot_occupancy(ax, obstacles, color="black", zorder=1)]
    for arr, rgb, z in ((region, (0.1, 0.7, 0.2), 2), (guideline, (0.9, 0.1, 0.1), 3)):
        if arr is None:
            continue
        a = np.asarray(arr, dtype=np.float64)
        if a.shape != obstacles.shape:
            raise ValueError(f"prediction shape {a.shape} differs from the map's {obstacles.shape}")
        alpha = (a >= threshold).astype(float) * 0.6 if threshold is not None else np.clip(a, 0, 1) * 0.8
        img = np.zeros(a.shape + (4,))
        img[..., :3] = rgb
        img[..., 3] = alpha
        artists.append(ax.imshow(img, interpolation="nearest", zorder=z,
                                 extent=(-0.5, a.shape[1] - 0.5, a.shape[0] - 0.5, -0.5)))
    if start is not None and goal is not None:
        artists += plot_endpoints(ax, start, goal, size=40)
    frame_map(ax, obstacles.shape)
    return artists


def plot_method_paths(ax: Any, blocked: np.ndarray, paths: Mapping[str, Sequence[Sequence[int]] | None],
                      start: Sequence[int], goal: Sequence[int], *, linewidth: float = 1.8,
                      legend: bool = True) -> list[Any]:
    """Every method's path (planning-grid ``(row, col)`` cells) on the same planning grid.

    Paths are offset by a fraction of a cell per method so that shared segments stay visible;
    ``None`` (no path) is listed in the legend as "no path".
    """
    blocked = np.asarray(blocked, bool)
    artists: list[Any] = [plot_occupancy(ax, blocked, color="black", zorder=1)]
    n = max(1, len(paths))
    for i, (name, path) in enumerate(paths.items()):
        color = METHOD_COLORS.get(name)
        if path is None:
            artists += ax.plot([], [], color=color, label=f"{name}: no path")
            continue
        pts = np.asarray(path, dtype=float).reshape(-1, 2)
        off = (i - (n - 1) / 2) * 0.12
        artists += ax.plot(pts[:, 1] + off, pts[:, 0] + off, "-", color=color, linewidth=linewidth,
                           label=f"{name} ({len(pts) - 1})", zorder=3 + i)
    artists += plot_endpoints(ax, start, goal, size=40)
    frame_map(ax, blocked.shape)
    if legend:
        artists.append(ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.02), ncol=3, fontsize=6, frameon=False))
    return artists
