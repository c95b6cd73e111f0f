"""The one place that asks the NDR model about a planning problem.

:func:`predict_region` decides what the model sees and returns region and guideline probabilities
on the planning grid and at the map's resolution; everything downstream (priors, figures, JSON)
takes them from here. A ``grid``-mode model (the default ``general``) sees the planning grid itself
at 4 px per cell (:func:`ndrql.dataset.render.grid_input`), through the view in its config
(:mod:`ndrql.dataset.views`); a ``map``-mode model (the paper's) sees
the map as drawn (not inflated), resized so its longer side is 201 px and padded with obstacles
(:func:`ndrql.dataset.render.to_model_input`), with start and goal scaled along. Predictions given
instead of the model (``plan --prior-from``) arrive as :class:`GivenPredictions`
(:func:`load_predictions`); the oracle's as :func:`oracle_view`. Which of them a plan uses, and whether they can
guide it, is decided in :mod:`ndrql.pipeline.prior_stage`.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from ndrql.dataset.render import PX_PER_CELL, cell_means, cells_to_map, point_on_grid, to_model_input
from ndrql.maps.grid import GridMap, MODEL_SIDE, PlanningGrid
from ndrql.errors import NdrqlError
from ndrql.model.predict import GridPrediction, Prediction, load_predictor
from ndrql.model.symmetry import DEFAULT_COUNT as DEFAULT_SYMMETRIES
from ndrql.planning.methods import load_prior_file
from ndrql.synth.oracle import oracle_prediction

Point = tuple[int, int]


@dataclass(frozen=True)
class ModelView:
    """The model's predictions for one problem, at the map's resolution."""

    region: np.ndarray
    """Region probabilities, float64 ``(H, W)``."""
    guideline: np.ndarray | None
    """Guideline probabilities, float64 ``(H, W)``, or ``None`` for a model without guideline decoder."""
    info: dict[str, Any]
    """What the model saw (JSON ``model_input``): its input side, scale and where start and goal landed."""
    region_grid: np.ndarray | None = None
    """Region on the planning grid when the prediction was made there (grid-mode models, the oracle), else ``None``."""
    guideline_grid: np.ndarray | None = None
    """Guideline on the planning grid, as :attr:`region_grid`."""
    distance_grid: np.ndarray | None = None
    """Predicted distance to the goal per planning cell, in cells (models with a distance head), else ``None``."""


def model_input_points(obstacles: np.ndarray, start: Point, goal: Point) -> dict[str, Any]:
    """Where start and goal land in the model's 201x201 input (:func:`ndrql.dataset.render.to_model_input`).

    A map that is not 201x201 is resized and padded for the model; a point whose resized pixel is an
    obstacle is moved to the nearest free pixel there. That is reported with a warning (the model
    then sees the point somewhere else; planning still uses the exact point).
    """
    h, w = obstacles.shape
    _, s_in, g_in, scale = to_model_input(obstacles, start, goal)
    nh = max(1, round(h * scale))
    moved = []
    for name, p, q in (("start", start, s_in), ("goal", goal, g_in)):
        want = p if scale == 1.0 and (h, w) == (MODEL_SIDE, MODEL_SIDE) else point_on_grid(p, nh / h, MODEL_SIDE)
        moved.append(tuple(want) != tuple(q))
        if moved[-1]:
            warnings.warn(f"{name} {p[0]},{p[1]} falls on an obstacle of the model's {MODEL_SIDE}x{MODEL_SIDE} input "
                          f"(the map resized by {scale:.3f}); the model sees it at {q[0]},{q[1]}", UserWarning, stacklevel=3)
    return {"side": MODEL_SIDE, "scale": scale, "start": list(s_in), "goal": list(g_in),
            "moved": {"start": moved[0], "goal": moved[1]}}


def _grid_to_map(cells: np.ndarray, grid: PlanningGrid) -> np.ndarray:
    """Values per planning cell -> the map's pixels, each pixel its cell's value (for figures, JSON and the
    guideline's mass on obstacles; the same rule as :meth:`ndrql.model.predict.Predictor.predict`)."""
    return cells_to_map(cells, grid.source_shape, grid.cell_size)


def predict_on_grid(predictor: Any, blocked: np.ndarray, start_cell: Point, goal_cell: Point,
                    unknown: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None, dict[str, Any], np.ndarray | None]:
    """A grid-mode model's region, guideline and goal distance (cells; ``None`` for a model without a distance
    head) per cell of the planning grid ``blocked``, from one forward pass of the model that serves the grid
    (:meth:`~ndrql.model.predict.Predictor.predict_view`: the weights' large-grid companion on a grid the view
    merges), and what it saw: the input's side, where start and goal landed, the view and how many cells along
    each side it merged into one (``merged``). A model with a companion also names the weights file that served
    (``weights_file``) and, on ONNX Runtime, the graph that ran (``runs_file``). Whether the prediction can guide
    planning is the judge's (:func:`ndrql.pipeline.judge.judge`), not this function's. ``unknown``: the planning
    cells unknown to the planner, for a model with the unknown channel (``info["unknown_cells"]`` counts them)."""
    sees = unknown is not None and bool(getattr(predictor, "sees_unknown", False))
    out = predictor.predict_view(blocked, start_cell, goal_cell, unknown=unknown) if sees else \
        predictor.predict_view(blocked, start_cell, goal_cell)
    served = predictor.serving(max(np.shape(blocked))) if getattr(predictor, "merged_weights", None) is not None \
        else None
    seen = out.seen
    info = {"mode": "grid", "side": int(seen.image.shape[0]), "start": [int(v) for v in seen.start],
            "goal": [int(v) for v in seen.goal],
            "view": str(predictor.view), "merged": int(seen.factor)}
    if sees:
        info["unknown_cells"] = int((np.asarray(unknown, bool) & ~np.asarray(blocked, bool)).sum())
    if served is not None:
        info["weights_file"] = served.weights_file.name
        info["companion"] = served is not predictor
        if served.graph_file is not None:
            info["runs_file"] = str(served.graph_file)
    return out.region, out.guideline, info, out.distance


def _on_grid(region: np.ndarray, guide: np.ndarray | None, grid: PlanningGrid, info: dict[str, Any],
             distance: np.ndarray | None = None) -> ModelView:
    """A view from values per planning cell of ``grid``: each map pixel its cell's value."""
    return ModelView(region=_grid_to_map(region, grid), guideline=None if guide is None else _grid_to_map(guide, grid),
                     info=info, region_grid=region, guideline_grid=guide, distance_grid=distance)


def oracle_view(grid: PlanningGrid) -> ModelView:
    """The oracle's region and guideline: the planning grid's own shortest path drawn like the dataset's labels
    (:func:`ndrql.synth.oracle.oracle_prediction`). A diagnostic of how far the model is from a perfect
    prediction, never a method: it needs the answer."""
    region, guide = oracle_prediction(grid.blocked, grid.start, grid.goal, PX_PER_CELL)
    return _on_grid(cell_means(region, grid.shape), cell_means(guide, grid.shape), grid,
                    {"oracle": True, "px_per_cell": PX_PER_CELL})


def predict_region(predictor: Any, grid_map: GridMap, grid: PlanningGrid, start: Point, goal: Point,
                   unknown: np.ndarray | None = None) -> ModelView:
    """Region and guideline for planning ``grid`` from ``start`` to ``goal`` (map pixels), at the map's resolution.

    ``predictor``: a loaded model (:func:`ndrql.model.predict.load_predictor`). What the model sees
    follows its input mode (``predictor.input_mode``, from its checkpoint): ``grid`` models see the
    planning grid itself at 4 px per cell (start and goal in their cells' centres), through the view they
    were trained under (``predictor.view``: ``coarse:128`` merges a grid above 128 cells), and predict on it;
    ``map`` models (the paper's) see the map resized to 201 px. ``unknown``: the planning cells unknown to the
    planner (a belief map), seen by a grid-mode model with the unknown channel only.
    """
    if getattr(predictor, "input_mode", "map") == "grid":
        region, guide, info, distance = predict_on_grid(predictor, grid.blocked, grid.start, grid.goal, unknown)
        return _on_grid(region, guide, grid, info, distance)
    info = model_input_points(grid_map.obstacles, start, goal)
    pred = predictor.predict(grid_map.obstacles, start, goal)
    region = np.asarray(pred.region, dtype=np.float64)
    guideline = None if pred.guideline is None else np.asarray(pred.guideline, dtype=np.float64)
    return ModelView(region=region, guideline=guideline, info=info)


def view_prediction(view: ModelView, grid: PlanningGrid, size: int) -> Any:
    """``view`` as a :class:`~ndrql.model.predict.Prediction` (what a prediction file holds,
    :func:`prediction_arrays`): its per-cell arrays with the grid they were made on when it has them."""
    cells = None
    if view.region_grid is not None:
        cells = GridPrediction(size, grid.blocked, grid.start, grid.goal, view.region_grid, view.guideline_grid,
                               view.distance_grid)
    return Prediction(view.region, view.guideline, cells)


def predict_priors(
    obstacles: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    weights: str | os.PathLike | None = None,
    threads: int = 1,
    backend: str = "auto",
    size: int | None = None,
    symmetries: int = DEFAULT_SYMMETRIES,
) -> tuple[np.ndarray, np.ndarray | None]:
    """NDR region and guideline probabilities at the map's resolution, from the trained model.

    ``start``/``goal`` are ``(row, col)`` map pixels. What the model sees follows its input mode
    (:meth:`ndrql.model.predict.Predictor.predict`): the paper's model sees the map resized to 201 px;
    a grid-mode model (the default ``general``) sees the safe planning grid of ``size`` cells (default:
    the size ``ndrql plan --size auto`` picks) and each map pixel takes its cell's mean. The model is
    loaded once per process (:func:`ndrql.model.predict.load_predictor`). ``threads``: threads for the
    forward pass (default 1: one map gains little from more, and a busy machine makes more threads
    much slower); ``backend``: see :func:`~ndrql.model.predict.load_predictor`; ``symmetries``: a
    grid-mode model's prediction averaged over that many orientations of the grid, as ``ndrql plan``
    does. The guideline is ``None`` for a model without the guideline decoder.
    """
    predictor = load_predictor(weights, threads, backend, symmetries)
    pred = predictor.predict(np.asarray(obstacles, dtype=bool), tuple(start), tuple(goal), size)
    guideline = None if pred.guideline is None else np.asarray(pred.guideline, dtype=np.float64)
    return np.asarray(pred.region, dtype=np.float64), guideline


@dataclass(frozen=True)
class GivenPredictions:
    """Predictions read from a file (``plan --prior-from FILE.npz``): at the map's resolution, and, from
    a grid-mode model (``ndrql predict``), on the planning grid it saw."""

    region: np.ndarray
    """Region at the map's resolution."""
    guideline: np.ndarray | None
    """Guideline at the map's resolution."""
    grid: GridPrediction | None = None
    """The per-cell arrays and the grid they were made on, or ``None``."""

    def on(self, grid: PlanningGrid) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None] | None:
        """The per-cell region, guideline and goal distance (``None`` without one) when they were made on
        exactly this planning grid (same cells blocked, same start and goal cells), else ``None`` (the
        map-resolution arrays are averaged onto it)."""
        g = self.grid
        if g is None or g.blocked.shape != grid.shape or not np.array_equal(g.blocked, grid.blocked):
            return None
        if tuple(g.start) != tuple(grid.start) or tuple(g.goal) != tuple(grid.goal):
            return None
        return g.region, g.guideline, g.distance


#: Arrays of a prediction file that describe the planning grid a grid-mode model saw (``ndrql predict``).
GRID_KEYS = ("grid_size", "grid_blocked", "grid_start", "grid_goal", "grid_region", "grid_guideline")
#: Optional with them: the goal distance per cell of a model with a distance head.
GRID_DISTANCE_KEY = "grid_distance"


def prediction_arrays(pred: Any) -> dict[str, np.ndarray]:
    """A :class:`~ndrql.model.predict.Prediction` as the arrays of a prediction file, read back by
    :func:`load_predictions`: the map-resolution arrays as float32, a grid-mode model's per-cell arrays as
    float64 (so that ``plan --prior-from`` on the same grid plans exactly as ``plan`` with the model)."""
    out = {"region": np.asarray(pred.region, np.float32)}
    if pred.guideline is not None:
        out["guideline"] = np.asarray(pred.guideline, np.float32)
    g = pred.grid
    if g is not None and g.guideline is not None:
        out.update(grid_size=np.array(g.size), grid_blocked=np.asarray(g.blocked, bool), grid_start=np.array(g.start),
                   grid_goal=np.array(g.goal), grid_region=np.asarray(g.region, np.float64),
                   grid_guideline=np.asarray(g.guideline, np.float64))
        if g.distance is not None:
            out[GRID_DISTANCE_KEY] = np.asarray(g.distance, np.float64)
    return out


def load_predictions(path: str | os.PathLike) -> GivenPredictions:
    """Read a prediction file: ``region`` and ``guideline`` at the map's resolution (required) and the
    grid arrays of :data:`GRID_KEYS` (optional, all or none; checked against each other)."""
    region, guideline = load_prior_file(os.fspath(path))
    with np.load(path, allow_pickle=False) as data:
        present = [k for k in GRID_KEYS if k in data.files]
        if not present:
            return GivenPredictions(region, guideline)
        if len(present) != len(GRID_KEYS):
            missing = ", ".join(k for k in GRID_KEYS if k not in present)
            raise NdrqlError(f"{path}: has grid arrays but not {missing}; write it with ndrql predict or drop the grid_* arrays")
        blocked = np.asarray(data["grid_blocked"], bool)
        cells = [tuple(int(v) for v in np.asarray(data[k]).reshape(-1)) for k in ("grid_start", "grid_goal")]
        arrays = [np.asarray(data[k], np.float64) for k in ("grid_region", "grid_guideline")]
        size = int(np.asarray(data["grid_size"]).reshape(-1)[0]) if np.asarray(data["grid_size"]).size else 0
        distance = np.asarray(data[GRID_DISTANCE_KEY], np.float64) if GRID_DISTANCE_KEY in data.files else None
    if blocked.ndim != 2 or any(a.shape != blocked.shape for a in arrays) or any(len(c) != 2 for c in cells):
        raise NdrqlError(f"{path}: grid_region, grid_guideline and grid_blocked must have one 2-D shape, "
                         f"grid_start and grid_goal two numbers each")
    if any(not np.all(np.isfinite(a)) or a.min() < 0 or a.max() > 1 for a in arrays):
        raise NdrqlError(f"{path}: grid_region and grid_guideline must hold probabilities in [0, 1]")
    if distance is not None and (distance.shape != blocked.shape or not np.all(np.isfinite(distance))):
        raise NdrqlError(f"{path}: grid_distance must be finite and have grid_blocked's shape")
    return GivenPredictions(region, guideline,
                            GridPrediction(size, blocked, cells[0], cells[1], arrays[0], arrays[1], distance))
