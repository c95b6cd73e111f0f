"""Oracle predictions: the labels a perfect NDR model would predict, from the planning grid itself.

The NDR model predicts a region and a guideline where the optimal path runs. The oracle draws them
from the planning grid's own shortest path, exactly as the dataset draws its labels
(:mod:`ndrql.synth.labels`): the 8-connected shortest path without corner cutting on the grid,
shortcut on the grid, its waypoints mapped to the centres of their cells at ``px_per_cell`` pixels
per cell (``cell * px + (px - 1) / 2``), drawn :data:`~ndrql.synth.labels.GUIDE_PX` wide and dilated
by :data:`~ndrql.synth.labels.REGION_PX`. Area-averaging the two images back to the grid
(:func:`ndrql.maps.grid.area_downscale`) gives the oracle priors of NDR-CRF and NDR-QI (Eqs. 3 and
6): the ceiling that a model's predictions can at best reach.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ndrql.errors import NdrqlError
from ndrql.synth.labels import GUIDE_PX, REGION_PX, dilate_region, draw_guideline, near_optimal_path

#: Where the NDR priors of an experiment can come from: the model, or this oracle (a diagnostic).
PRIOR_SOURCES = ("model", "oracle")

#: What every output prints where it would name the model's weights, when the priors are the oracle's.
ORACLE_NAME = "oracle priors"


def cell_centres(cells: np.ndarray, px_per_cell: int) -> np.ndarray:
    """Pixel centres ``cell * px + (px - 1) / 2`` of ``(row, col)`` cells, as floats."""
    return np.asarray(cells, dtype=np.float64) * px_per_cell + (px_per_cell - 1) / 2


def oracle_prediction(
    blocked: np.ndarray, start_cell: Sequence[int], goal_cell: Sequence[int], px_per_cell: int = 4
) -> tuple[np.ndarray, np.ndarray]:
    """``(region, guideline)``, float32 in {0, 1} at ``(h * px_per_cell, w * px_per_cell)``.

    Drawn from the grid's own near-optimal path between the two cells (see the module docstring).
    Raises :class:`~ndrql.errors.PointError` for a cell off the grid or blocked and
    :class:`~ndrql.errors.NoPathError` when the cells are not connected.
    """
    if int(px_per_cell) < 1:
        raise NdrqlError(f"px_per_cell must be >= 1, got {px_per_cell}")
    blocked = np.asarray(blocked, dtype=bool)
    px = int(px_per_cell)
    waypoints = near_optimal_path(blocked, start_cell, goal_cell)
    shape = (blocked.shape[0] * px, blocked.shape[1] * px)
    guideline = draw_guideline(shape, cell_centres(waypoints, px), GUIDE_PX)
    region = dilate_region(guideline, REGION_PX)
    return region.astype(np.float32), guideline.astype(np.float32)
