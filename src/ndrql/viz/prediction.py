"""Region and guideline overlays of an NDR prediction (paper Fig. 4 style)."""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ndrql.viz.maps import plot_endpoints, plot_occupancy
from ndrql.viz.style import GUIDELINE_CMAP, REGION_CMAP, legend_below, probability_colorbar


def plot_probability_overlay(ax: Any, obstacles: np.ndarray, prob: np.ndarray, *, cmap: str | None = None,
                             start: Sequence[float] | None = None, goal: Sequence[float] | None = None,
                             title: str | None = None, alpha: float = 0.85, kind: str = "region",
                             colorbar: bool = True) -> list[Any]:
    """The map in black with ``prob`` (0..1) drawn on top, a colour bar beside it and start and goal
    in a legend below (:mod:`ndrql.viz.style`); returns the artists.

    ``kind`` (``region`` or ``guideline``) picks the colour map of ``plan``'s figures unless ``cmap`` is given.
    """
    cmap = cmap or (GUIDELINE_CMAP if kind == "guideline" else REGION_CMAP)
    masked = np.ma.masked_less(np.asarray(prob, float), 0.02)
    image = ax.imshow(masked, cmap=cmap, vmin=0.0, vmax=1.0, alpha=alpha, interpolation="nearest", zorder=1)
    artists = [image, plot_occupancy(ax, obstacles, zorder=2)]
    if colorbar:
        artists.append(probability_colorbar(ax, image, f"{kind} probability"))
    return _finish_overlay(ax, artists, start, goal, title)


def _finish_overlay(ax: Any, artists: list[Any], start: Sequence[float] | None, goal: Sequence[float] | None,
                    title: str | None) -> list[Any]:
    """Start and goal with their legend below, the title, no ticks, equal aspect; returns ``artists`` with them."""
    if start is not None and goal is not None:
        artists += list(plot_endpoints(ax, start, goal))
        artists.append(legend_below(ax, ncol=2))
    if title:
        ax.set_title(title, fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_aspect("equal")
    return artists


def plot_label_comparison(ax: Any, obstacles: np.ndarray, pred: np.ndarray, label: np.ndarray, *,
                          title: str | None = None) -> list[Any]:
    """True positives green, false positives red, false negatives blue, over the map."""
    rgb = np.ones(obstacles.shape + (3,))
    rgb[obstacles] = 0.2
    pred, label = np.asarray(pred, bool), np.asarray(label, bool)
    rgb[pred & label] = (0.2, 0.7, 0.2)
    rgb[pred & ~label] = (0.9, 0.2, 0.2)
    rgb[~pred & label] = (0.2, 0.3, 0.9)
    artists = [ax.imshow(rgb, interpolation="nearest")]
    if title:
        ax.set_title(title)
    ax.set_axis_off()
    return artists


def plot_distance_field(ax: Any, obstacles: np.ndarray, distance: np.ndarray, *, start: Sequence[float] | None = None,
                        goal: Sequence[float] | None = None, title: str | None = None, levels: int = 12) -> list[Any]:
    """A predicted distance to the goal (cells, at the map's pixels) as colour with iso-distance lines, the
    map in black on top, start and goal in a legend below; returns the artists. The lines should wrap
    around walls where the way does."""
    d = np.ma.masked_where(np.asarray(obstacles, bool), np.asarray(distance, float))
    image = ax.imshow(d, cmap="viridis_r", interpolation="nearest", zorder=1)
    artists = [image, plot_occupancy(ax, obstacles, zorder=2)]
    if d.count() and np.ptp(d.compressed()) > 0:
        artists.append(ax.contour(d, levels=levels, colors="white", linewidths=0.5, alpha=0.7, zorder=3))
    bar = ax.figure.colorbar(image, ax=ax, fraction=0.046, pad=0.04)
    bar.set_label("distance to the goal (cells)", fontsize=8)
    artists.append(bar)
    return _finish_overlay(ax, artists, start, goal, title)
