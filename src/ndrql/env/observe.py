"""What the goal-conditioned environment shows its agent: image channels and the prior channels.

The image is channel-first float32 in ``[0, 1]``: :data:`CHANNELS` always, then :data:`PRIOR_CHANNELS`
when a prior is asked for. ``full`` shows the whole planning grid (padded with obstacle cells to a
fixed side); ``ego`` shows a square window centred on the agent (cells off the grid are obstacles).

The priors are the NDR model's region and guideline (or an oracle's: what a perfect model would
predict, drawn from the grid's own shortest path), area-averaged onto the planning grid, the
quantities Eqs. 3-7 of the paper turn into rewards and an initial Q-table; optionally also the goal
distance (:data:`DISTANCE_CHANNEL`): the model's distance head (beyond the paper; the term ``ndrql plan``
puts in Eq. 6) or the oracle's exact moves to the goal.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ndrql.env.sources import EnvProblem
from ndrql.errors import NdrqlError
from ndrql.maps.grid import area_downscale, bfs_distances
from ndrql.maps.safe import cell_size_px
from ndrql.pipeline.predictions import predict_on_grid
from ndrql.synth.oracle import oracle_prediction

Cell = tuple[int, int]

#: Image channels, in order.
CHANNELS = ("obstacle", "visited", "agent", "goal")
#: Channels added by a prior, in order.
PRIOR_CHANNELS = ("region", "guideline")
#: The optional channel after :data:`PRIOR_CHANNELS`: the goal distance, :func:`distance_channel`.
DISTANCE_CHANNEL = "distance"
#: Views of the grid.
VIEWS = ("full", "ego")
#: Priors: none, the NDR model's predictions, or the oracle's (from the grid's shortest path).
PRIORS = ("none", "ndr", "oracle")


def grid_image(blocked: np.ndarray, visited: np.ndarray, agent: Cell, goal: Cell,
               prior: np.ndarray | None = None) -> np.ndarray:
    """The ``(C, h, w)`` float32 channels of the whole grid (``prior``: ``(2, h, w)`` region, guideline, or
    ``(3, h, w)`` with the goal distance)."""
    h, w = blocked.shape
    n = len(CHANNELS) + (0 if prior is None else len(prior))
    img = np.zeros((n, h, w), dtype=np.float32)
    img[0] = blocked
    img[1] = visited
    img[2][agent] = 1.0
    img[3][goal] = 1.0
    if prior is not None:
        img[len(CHANNELS):] = prior
    return img


def full_view(image: np.ndarray, side: int) -> np.ndarray:
    """``image`` padded at the bottom and right to ``(C, side, side)``, padding = obstacle cells."""
    c, h, w = image.shape
    if h > side or w > side:
        raise NdrqlError(f"a {h}x{w} planning grid does not fit this env's {side}x{side} view; "
                         f"make the env with size >= {max(h, w)}")
    out = np.zeros((c, side, side), dtype=np.float32)
    out[0] = 1.0
    out[:, :h, :w] = image
    return out


def ego_view(image: np.ndarray, agent: Cell, side: int) -> np.ndarray:
    """The ``(C, side, side)`` window of ``image`` centred on ``agent`` (odd ``side``), off-grid = obstacle."""
    c, h, w = image.shape
    half = side // 2
    out = np.zeros((c, side, side), dtype=np.float32)
    out[0] = 1.0
    r0, c0 = agent[0] - half, agent[1] - half
    rs, re = max(0, r0), min(h, r0 + side)
    cs, ce = max(0, c0), min(w, c0 + side)
    out[:, rs - r0:re - r0, cs - c0:ce - c0] = image[:, rs:re, cs:ce]
    return out


def goal_vector(agent: Cell, goal: Cell, side: int) -> np.ndarray:
    """``(goal - agent) / side``, float32 in ``[-1, 1]``: where the goal lies, for views that may not show it."""
    d = (np.asarray(goal, dtype=np.float32) - np.asarray(agent, dtype=np.float32)) / float(side)
    return np.clip(d, -1.0, 1.0).astype(np.float32)


def distance_channel(cells: np.ndarray, side: int) -> np.ndarray:
    """A goal distance in cells as an image channel: ``d / (d + side)`` in ``[0, 1)`` (0 at the goal, 1/2 one
    grid side away; the order of cells is kept however long the detour), 1 where ``d`` is negative
    (the goal cannot be reached)."""
    d = np.asarray(cells, dtype=np.float64)
    return np.where(d < 0, 1.0, np.maximum(d, 0.0) / (np.maximum(d, 0.0) + float(side))).astype(np.float32)


def oracle_prior(problem: EnvProblem, distance_side: int | None = None) -> np.ndarray:
    """``(2, h, w)`` region and guideline of the oracle (:func:`ndrql.synth.oracle.oracle_prediction`) on the
    grid; with a ``distance_side`` ``(3, h, w)``, the third the exact 4-connected moves to the goal
    (:func:`distance_channel` with that side)."""
    region, guideline = oracle_prediction(problem.blocked, problem.start, problem.goal, px_per_cell=4)
    shape = problem.blocked.shape
    layers = [area_downscale(region, shape), area_downscale(guideline, shape)]
    if distance_side is not None:
        layers.append(distance_channel(bfs_distances(problem.blocked, problem.goal), distance_side))
    return np.stack(layers).astype(np.float32)


def _grid_area(values: np.ndarray, shape: tuple[int, int], rule: str, size: int) -> np.ndarray:
    """Map-resolution ``values`` averaged onto the planning cells (the safe grid's square cells for ``safe``)."""
    if rule != "safe":
        return area_downscale(values, shape)

    cs = cell_size_px(values.shape, size)
    rows, cols = int(round(shape[0] * cs)), int(round(shape[1] * cs))
    canvas = np.zeros((max(rows, values.shape[0]), max(cols, values.shape[1])))
    canvas[:values.shape[0], :values.shape[1]] = values
    return area_downscale(canvas[:rows, :cols], shape)


_NO_DISTANCE = ("prior_distance needs weights with a distance head (the shipped general weights); "
                "these have none (or use prior='oracle')")


def ndr_prior(predictor: Any, problem: EnvProblem, rule: str, size: int, distance: bool = False) -> np.ndarray:
    """``(2, h, w)`` region and guideline of the NDR model on the planning grid: a grid-mode model (the
    default ``general``) predicts on the grid itself (per cell, through its view); a map-mode model (the paper's)
    on the source map, averaged onto the grid. With ``distance`` ``(3, h, w)``, the third the model's
    goal distance (:func:`distance_channel` with side ``size``; only models with a distance head have one)."""
    grid_mode = getattr(predictor, "input_mode", "map") == "grid"
    if grid_mode:  # sees the planning grid itself, as ndrql plan's model does
        r, gl, _, d = predict_on_grid(predictor, problem.blocked, problem.start, problem.goal)  # plan's own call
        layers = [r, r if gl is None else gl]
        if distance:
            if d is None:
                raise NdrqlError(_NO_DISTANCE)
            layers.append(distance_channel(d, size))
        return np.stack(layers).astype(np.float32)
    if distance:
        raise NdrqlError(_NO_DISTANCE)
    if problem.source is None:
        raise NdrqlError("the paper's NDR model needs the map in pixels; this problem came as a planning grid "
                         "(use a grid-mode model such as the default general weights, or prior='oracle')")
    pred = predictor.predict(problem.source.obstacles, problem.source.start, problem.source.goal)
    guideline = pred.guideline if pred.guideline is not None else pred.region
    shape = problem.blocked.shape
    return np.stack([_grid_area(np.asarray(pred.region, np.float64), shape, rule, size),
                     _grid_area(np.asarray(guideline, np.float64), shape, rule, size)]).astype(np.float32)
