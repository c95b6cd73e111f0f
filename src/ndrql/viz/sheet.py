"""Contact sheets of model inputs with their labels (``ndrql data show``)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ndrql.viz.maps import new_figure

#: Colours shared with the plan figures: region green, guideline orange.
REGION_RGB = (0.2, 0.7, 0.3)
GUIDE_RGB = (1.0, 0.55, 0.0)


def sample_image(r) -> np.ndarray:
    """RGB image of a rendered sample: free white, obstacles dark, region tinted, guideline on top."""
    img = np.where(r.obstacles[..., None], 0.15, 1.0) * np.ones(3)
    region = r.region & ~r.obstacles
    img[region] = 0.55 * img[region] + 0.45 * np.array(REGION_RGB)
    img[r.guideline] = GUIDE_RGB
    return img


def sheet_grid(count: int) -> tuple[int, int]:
    """Rows and columns of the near-square grid that holds ``count`` items."""
    n = max(1, count)
    cols = math.ceil(math.sqrt(n))
    return math.ceil(n / cols), cols


def draw_sheet(fig, items: list, title: str = "") -> list:
    """Draw ``(label, Rendered | None)`` items on ``fig`` in a near-square grid; returns the axes."""
    rows, cols = sheet_grid(len(items))
    axes = []
    for k, (label, r) in enumerate(items):
        ax = fig.add_subplot(rows, cols, k + 1)
        if r is None:
            ax.text(0.5, 0.5, "unusable at this grid", ha="center", va="center", fontsize=7)
        else:
            ax.imshow(sample_image(r), interpolation="nearest")
            ax.plot([r.start[1]], [r.start[0]], "o", color="red", ms=4)
            ax.plot([r.goal[1]], [r.goal[0]], "o", color="blue", ms=4)
        ax.set_title(label, fontsize=7)
        ax.set_xticks([])
        ax.set_yticks([])
        axes.append(ax)
    if title:
        fig.suptitle(title, fontsize=9)
    return axes


def contact_sheet(items: list, title: str = "", fig: Any = None) -> Any:
    """:func:`draw_sheet` on ``fig``, or on a new figure sized for the grid of items and laid out tight;
    returns the figure (``ndrql data show`` saves it)."""
    own = fig is None
    if own:
        rows, cols = sheet_grid(len(items))
        fig = new_figure(figsize=(2.2 * cols, 2.3 * rows + 0.4))
    draw_sheet(fig, items, title)
    if own:
        fig.tight_layout()
    return fig
