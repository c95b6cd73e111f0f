"""The figure of ``ndrql reproduce partial``: one map the planner does not fully know, in four panels.

1. the true map; 2. the belief as the planner sees it (:meth:`~ndrql.maps.belief.Belief.planner_obstacles` with the
unknown pixels counted free: a hidden obstacle is not drawn) with its unknown pixels shaded; 3. the region and
guideline of the source that served NDR-QL (the model, or the exact prior of the belief), on the same view;
4. NDR-QL's greedy path learned on the true map against the A* optimum (:func:`ndrql.viz.plan.plan_figure`), with
the true obstacles the belief did not know in dark red (what the agent ran into). Only panels 1 and 4 show the
truth. Plot functions draw on ``ax`` and return their artists; the builder returns the figure; nothing calls ``show``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ndrql.viz.maps import figure_or_new, frame_map, plot_endpoints, plot_occupancy
from ndrql.viz.overlays import plot_prediction
from ndrql.viz.plan import plan_figure
from ndrql.viz.style import legend_below

#: Colour of the pixels unknown to the planner.
UNKNOWN_COLOR = "tab:purple"
#: Colour of the true obstacles the belief did not know (panel 4).
UNSEEN_COLOR = "darkred"


def plot_belief(ax: Any, obstacles: np.ndarray, unknown: np.ndarray, start: Any, goal: Any, *,
                title: str | None = None) -> list[Any]:
    """The planner's obstacles with its unknown pixels shaded; returns the artists."""
    artists = [plot_occupancy(ax, obstacles, color="black", zorder=1),
               plot_occupancy(ax, unknown, color=UNKNOWN_COLOR, alpha=0.35, zorder=2)]
    artists += plot_endpoints(ax, start, goal, size=40)
    frame_map(ax, np.shape(obstacles))
    if title:
        artists.append(ax.set_title(title, fontsize=9))
    return artists


def prediction_title(source: str | None) -> str:
    """Panel 3's title: what served NDR-QL's priors (the record's ``ndr.served``; ``None``: nothing served)."""
    if source == "model":
        return "the model's region (green) and guideline (red)\non the belief"
    if source is None:
        return "no prior served: NDR-QL fell back to IQL-BFS"
    return f"the {source} prior of the belief:\nregion (green) and guideline (red)"


def plot_unseen(ax: Any, truth: np.ndarray, belief: Any) -> list[Any]:
    """The true obstacles the belief did not know (true obstacle pixels it counts free) in :data:`UNSEEN_COLOR`, and
    the axes' legend redrawn with an entry for them; returns the artists."""
    from matplotlib.patches import Patch

    unseen = np.asarray(truth, dtype=bool) & ~belief.planner_obstacles("free")
    artists = [plot_occupancy(ax, unseen, color=UNSEEN_COLOR, zorder=3)]
    old = ax.get_legend()
    handles = list(old.legend_handles) if old is not None else []
    handles.append(Patch(color=UNSEEN_COLOR, label=f"obstacle the belief did not know ({int(unseen.sum()):,} px)"))
    artists.append(legend_below(ax, handles))
    return artists


def belief_figure(report: Any, belief: Any, region: np.ndarray | None, guideline: np.ndarray | None, *,
                  source: str | None = "model", title: str = "", fig: Any = None) -> Any:
    """Four panels of one plan on a belief map (module docstring). ``report``: the NDR-QL plan
    (:class:`~ndrql.api.PlanReport`) on the true map; ``belief``: its :class:`~ndrql.maps.belief.Belief`;
    ``region``/``guideline``: the served source's prediction on the belief at the map's resolution (``None``: none);
    ``source``: what served (``model``, ``exact``, ...; ``None``: NDR-QL fell back), for panel 3's title."""
    fig = figure_or_new(fig, (17.0, 5.9), dpi=90, layout="constrained")
    axes = fig.subplots(1, 4)
    truth, start, goal = report.grid_map.obstacles, report.start, report.goal
    plot_occupancy(axes[0], truth, color="black")
    plot_endpoints(axes[0], start, goal, size=40)
    frame_map(axes[0], truth.shape)
    axes[0].set_title("true map", fontsize=9)
    seen = belief.planner_obstacles("free")  # the planner's view: unknown pixels free, hidden obstacles not drawn
    share = float(belief.unknown_share(truth))
    plot_belief(axes[1], seen, belief.unknown, start, goal,
                title=f"belief ({belief.kind}), the planner's view:\n{share:.0%} of the free space unknown (shaded)")
    if region is not None and source is not None:
        plot_prediction(axes[2], seen, region, guideline, start, goal)
        plot_occupancy(axes[2], belief.unknown, color=UNKNOWN_COLOR, alpha=0.15, zorder=1)
        axes[2].set_title(prediction_title(source), fontsize=9)
    else:
        plot_belief(axes[2], seen, belief.unknown, start, goal,
                    title=prediction_title(None) if source is None else "no prediction")
    plan_figure(report, ax=axes[3])
    plot_unseen(axes[3], truth, belief)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


__all__ = ["UNKNOWN_COLOR", "UNSEEN_COLOR", "belief_figure", "plot_belief", "plot_unseen", "prediction_title"]
