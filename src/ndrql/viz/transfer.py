"""The figure ``ndrql reproduce transfer`` writes: predictions against the oracle, one map per family.

It draws results already computed (it runs nothing): for each family, one planning problem on its
safe grid with the model's region (green) and guideline (red) in the top row and the oracle's (the
grid's own shortest path drawn as the dataset draws its labels) in the bottom row, all as cell means.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ndrql.viz.maps import figure_or_new
from ndrql.viz.overlays import plot_prediction

Point = tuple[int, int]


@dataclass(frozen=True)
class PredictionPanel:
    """One column of the figure: a family's problem on the grid and both predictions on its cells."""

    family: str
    blocked: np.ndarray
    start: Point
    goal: Point
    model: tuple[np.ndarray, ...]
    """Region and guideline on the cells (and the goal distance of a model with a distance head, not drawn)."""
    oracle: tuple[np.ndarray, ...]
    title: str = ""


def transfer_figure(panels: Sequence[PredictionPanel], model_label: str, fig: Any = None, columns: int = 6) -> Any:
    """Model (upper row of each pair) over oracle (lower row), ``columns`` families per row pair.

    Draws on ``fig`` when given (a bare :class:`matplotlib.figure.Figure` will do; its size and layout
    are the caller's), else on a new one of its own size with constrained layout.
    """
    if not panels:
        raise ValueError("no panels to draw")
    cols = min(columns, len(panels))
    pairs = -(-len(panels) // cols)
    fig = figure_or_new(fig, (2.2 * cols, 4.6 * pairs), layout="constrained")
    axes = fig.subplots(2 * pairs, cols, squeeze=False)
    for ax in axes.ravel():
        ax.set_axis_off()
    for k, p in enumerate(panels):
        r, c = 2 * (k // cols), k % cols
        for row, (label, (region, guide, *_)) in enumerate(((model_label, p.model), ("oracle", p.oracle))):
            ax = axes[r + row, c]
            ax.set_axis_on()
            plot_prediction(ax, p.blocked, region, guide, p.start, p.goal)
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"{p.family}{' ' + p.title if p.title else ''}\n{label}" if row == 0 else label, fontsize=8)
    fig.suptitle(f"Predictions on the safe planning grid: {model_label} (upper) vs oracle (lower)", fontsize=10)
    return fig
