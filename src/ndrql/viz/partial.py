"""The figure of ``ndrql reproduce partial``: one map the planner does not fully know, in four panels.

True map; the belief (unknown pixels shaded); the model's region and guideline predicted on the belief; NDR-QL's
greedy path learned on the true map against the A* optimum (:func:`ndrql.viz.plan.plan_figure`). Plot functions
draw on ``ax`` and return their artists; the builder returns the figure; nothing calls ``show``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ndrql.viz.maps import figure_or_new, frame_map, plot_endpoints, plot_occupancy
from ndrql.viz.overlays import plot_prediction
from ndrql.viz.plan import plan_figure

#: Colour of the pixels unknown to the planner.
UNKNOWN_COLOR = "tab:purple"


def plot_belief(ax: Any, obstacles: np.ndarray, unknown: np.ndarray, start: Any, goal: Any, *,
                title: str | None = None) -> list[Any]:
    """The belief's obstacles with its unknown pixels shaded; returns the artists."""
    artists = [plot_occupancy(ax, obstacles, color="black", zorder=1),
               plot_occupancy(ax, unknown, color=UNKNOWN_COLOR, alpha=0.35, zorder=2)]
    artists += plot_endpoints(ax, start, goal, size=40)
    frame_map(ax, np.shape(obstacles))
    if title:
        artists.append(ax.set_title(title, fontsize=9))
    return artists


def belief_figure(report: Any, belief: Any, region: np.ndarray | None, guideline: np.ndarray | None, *,
                  title: str = "", fig: Any = None) -> Any:
    """Four panels of one plan on a belief map (module docstring). ``report``: the NDR-QL plan
    (:class:`~ndrql.api.PlanReport`) on the true map; ``belief``: its :class:`~ndrql.maps.belief.Belief`;
    ``region``/``guideline``: the model's prediction on the belief at the map's resolution (``None``: none)."""
    fig = figure_or_new(fig, (17.0, 5.6), dpi=90, layout="constrained")
    axes = fig.subplots(1, 4)
    truth, start, goal = report.grid_map.obstacles, report.start, report.goal
    plot_occupancy(axes[0], truth, color="black")
    plot_endpoints(axes[0], start, goal, size=40)
    frame_map(axes[0], truth.shape)
    axes[0].set_title("true map", fontsize=9)
    share = float(belief.unknown_share(truth))
    plot_belief(axes[1], belief.obstacles, belief.unknown, start, goal,
                title=f"belief ({belief.kind}): {share:.0%} of the free space unknown")
    if region is not None:
        plot_prediction(axes[2], belief.planner_obstacles("free"), region, guideline, start, goal)
        plot_occupancy(axes[2], belief.unknown, color=UNKNOWN_COLOR, alpha=0.15, zorder=1)
        axes[2].set_title("the model's region (green) and guideline (red) on the belief", fontsize=9)
    else:
        plot_belief(axes[2], belief.obstacles, belief.unknown, start, goal, title="no prediction")
    plan_figure(report, ax=axes[3])
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


__all__ = ["UNKNOWN_COLOR", "belief_figure", "plot_belief"]
