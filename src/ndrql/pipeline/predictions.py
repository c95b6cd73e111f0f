"""The one place that asks the NDR model about a planning problem.

:func:`predict_region` decides what the model sees and returns region and guideline probabilities
at the map's resolution; everything downstream (priors, figures, JSON) takes them from here. Today
the model sees the map as drawn (not inflated), resized so its longer side is 201 px and padded with
obstacles (:func:`ndrql.dataset.render.to_model_input`), with start and goal scaled along.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ndrql.dataset.encodings import encode_input
from ndrql.dataset.render import PX_PER_CELL, grid_input, point_on_grid, to_model_input
from ndrql.maps.grid import GridMap, MODEL_SIDE, PlanningGrid, area_downscale
from ndrql.errors import NdrqlError
from ndrql.maps.safe import grid_shape
from ndrql.model.predict import load_predictor
from ndrql.model.weights import resolve_weights
from ndrql.pipeline.report import StageClock
from ndrql.pipeline.settings import PlanSettings
from ndrql.planning.config import PriorConfig
from ndrql.planning.methods import Method, downscale_priors, get_method
from ndrql.planning.priors import adaptive_threshold
from ndrql.synth.oracle import ORACLE_NAME, oracle_prediction

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


def _grid_to_map(prob: np.ndarray, grid: PlanningGrid) -> np.ndarray:
    """Probabilities at 4 px per planning cell -> the map's pixels (nearest sample; for figures and JSON)."""
    h, w = grid.source_shape
    ch, cw = grid.cell_size
    rows = np.minimum(((np.arange(h) + 0.5) / ch * PX_PER_CELL).astype(int), prob.shape[0] - 1)
    cols = np.minimum(((np.arange(w) + 0.5) / cw * PX_PER_CELL).astype(int), prob.shape[1] - 1)
    return np.asarray(prob, np.float64)[rows[:, None], cols[None, :]]


def cell_means(prob: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Probabilities drawn at 4 px per cell (possibly padded) -> the planning grid of ``shape``: exact 4x4 means."""
    h, w = shape
    return area_downscale(np.asarray(prob, np.float64)[:h * PX_PER_CELL, :w * PX_PER_CELL], (h, w))


def to_map_pixels(prob: np.ndarray, shape: tuple[int, int], n: int) -> np.ndarray:
    """Probabilities at 4 px per cell of a grid of ``n`` cells -> the map's pixels: each pixel takes the
    mean of the 4x4 block of the cell holding its centre (cells of ``max(H, W) / n`` px, as :func:`ndrql.maps.safe.conservative_grid`)."""
    rows, cols = grid_shape(shape, n)
    cells = area_downscale(np.asarray(prob, np.float64)[:rows * PX_PER_CELL, :cols * PX_PER_CELL], (rows, cols))
    longest = max(shape)
    r = np.minimum(((np.arange(shape[0]) + 0.5) * n / longest).astype(int), rows - 1)
    c = np.minimum(((np.arange(shape[1]) + 0.5) * n / longest).astype(int), cols - 1)
    return cells[r[:, None], c[None, :]]


def predict_on_grid(predictor: Any, blocked: np.ndarray, start_cell: Point,
                    goal_cell: Point) -> tuple[np.ndarray, np.ndarray | None, dict[str, Any]]:
    """A grid-mode model's region and guideline at 4 px per cell of the planning grid ``blocked`` (padded to
    a square of ``4 max(h, w)`` px), and what it saw."""
    img, s, g = grid_input(blocked, start_cell, goal_cell, max(blocked.shape))
    r, gl = predictor.predict_batch(encode_input(img, s, g, predictor.encoding)[None])
    info = {"mode": "grid", "side": int(img.shape[0]), "start": list(s), "goal": list(g)}
    return r[0], None if gl is None else gl[0], info


def _on_grid(region_px: np.ndarray, guide_px: np.ndarray | None, grid: PlanningGrid, info: dict[str, Any]) -> ModelView:
    """A view from probabilities drawn at 4 px per cell of ``grid`` (padded): exact 4x4 means on the grid."""
    h, w = grid.shape
    crop = lambda a: np.asarray(a, np.float64)[:h * PX_PER_CELL, :w * PX_PER_CELL]  # noqa: E731
    return ModelView(region=_grid_to_map(crop(region_px), grid),
                     guideline=None if guide_px is None else _grid_to_map(crop(guide_px), grid),
                     info=info, region_grid=cell_means(region_px, grid.shape),
                     guideline_grid=None if guide_px is None else cell_means(guide_px, grid.shape))


def oracle_view(grid: PlanningGrid) -> ModelView:
    """The oracle's region and guideline: the planning grid's own shortest path drawn like the dataset's labels
    (:func:`ndrql.synth.oracle.oracle_prediction`). A diagnostic of how far the model is from a perfect
    prediction, never a method: it needs the answer."""
    region, guide = oracle_prediction(grid.blocked, grid.start, grid.goal, PX_PER_CELL)
    return _on_grid(region, guide, grid, {"oracle": True, "px_per_cell": PX_PER_CELL})


def predict_region(predictor: Any, grid_map: GridMap, grid: PlanningGrid, start: Point, goal: Point) -> ModelView:
    """Region and guideline for planning ``grid`` from ``start`` to ``goal`` (map pixels), at the map's resolution.

    ``predictor``: a loaded model (:func:`ndrql.model.predict.load_predictor`). What the model sees
    follows its input mode (``predictor.input_mode``, from its checkpoint): ``grid`` models see the
    planning grid itself at 4 px per cell (start and goal in their cells' centres) and predict on it;
    ``map`` models (the paper's) see the map resized to 201 px.
    """
    if getattr(predictor, "input_mode", "map") == "grid":
        region_px, guide_px, info = predict_on_grid(predictor, grid.blocked, grid.start, grid.goal)
        return _on_grid(region_px, guide_px, grid, info)
    info = model_input_points(grid_map.obstacles, start, goal)
    pred = predictor.predict(grid_map.obstacles, start, goal)
    region = np.asarray(pred.region, dtype=np.float64)
    guideline = None if pred.guideline is None else np.asarray(pred.guideline, dtype=np.float64)
    return ModelView(region=region, guideline=guideline, info=info)


def predict_priors(
    obstacles: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    weights: str | os.PathLike | None = None,
    threads: int = 1,
    backend: str = "auto",
) -> tuple[np.ndarray, np.ndarray | None]:
    """NDR region and guideline probabilities at the map's resolution, from the trained model.

    ``start``/``goal`` are ``(row, col)`` map pixels; maps of any size are resized for the model and
    the outputs mapped back (:func:`ndrql.dataset.render.to_model_input`). The model is loaded once
    per process (:func:`ndrql.model.predict.load_predictor`). ``threads``: threads for the forward
    pass (default 1: one 201x201 map gains little from more, and a busy machine makes more threads
    much slower); ``backend``: see :func:`~ndrql.model.predict.load_predictor`. The guideline is
    ``None`` for a model without the guideline decoder.
    """
    predictor = load_predictor(weights, threads, backend)
    pred = predictor.predict(np.asarray(obstacles, dtype=bool), tuple(start), tuple(goal))
    guideline = None if pred.guideline is None else np.asarray(pred.guideline, dtype=np.float64)
    return np.asarray(pred.region, dtype=np.float64), guideline


#: The region threshold (Eq. 7) below which the prediction is called uninformative: the model is not
#: even 50 % sure of any band of cells that joins start and goal.
MIN_THRESHOLD = 0.5
#: Largest share of the guideline's probability mass that may lie on obstacle pixels.
MAX_GUIDE_ON_OBSTACLES = 0.5


def prediction_quality(region_grid: np.ndarray, guideline: np.ndarray | None, obstacles: np.ndarray,
                       grid: PlanningGrid, cfg: Any) -> dict[str, Any]:
    """Whether the model's prediction can guide planning on this problem (JSON ``prediction_quality``).

    Uninformative when no region threshold >= :data:`MIN_THRESHOLD` makes the region connect start
    and goal on the planning grid (Eq. 7's search, ``cfg`` a :class:`~ndrql.planning.config.PriorConfig`),
    or when more than :data:`MAX_GUIDE_ON_OBSTACLES` of the guideline's mass lies on obstacles of
    the map (the model draws its path through walls).
    """
    thd = adaptive_threshold(region_grid, grid.blocked, grid.start, grid.goal, cfg)
    reasons = []
    if thd is None or thd < MIN_THRESHOLD:
        shown = "none" if thd is None else f"{thd:.2f}"
        reasons.append(f"no region threshold >= {MIN_THRESHOLD} connects start and goal (Eq. 7 threshold {shown})")
    on_obstacles = None
    if guideline is not None:
        mass = float(np.sum(guideline))
        if mass > 0:
            on_obstacles = float(np.sum(guideline, where=np.asarray(obstacles, dtype=bool))) / mass
            if on_obstacles > MAX_GUIDE_ON_OBSTACLES:
                reasons.append(f"{on_obstacles:.0%} of the guideline lies on obstacles")
        else:
            reasons.append("the guideline is empty")
    return {"informative": not reasons, "threshold": thd, "guideline_on_obstacles": on_obstacles,
            "reasons": reasons}


def fall_back(ms: Sequence[Method], region: np.ndarray, guideline_map: np.ndarray | None, grid_map: GridMap,
              grid: PlanningGrid, prior_config: PriorConfig, fallback: str | None, info: dict[str, Any]) -> list[Method]:
    """Judge the prediction (``info["prediction_quality"]``); when it is uninformative and ``fallback`` is
    set, each NDR method is replaced by the fallback (``info["fallback"]``), unless that one runs anyway."""
    quality = prediction_quality(region, guideline_map, grid_map.obstacles, grid, prior_config)
    info["prediction_quality"] = quality
    if quality["informative"] or fallback is None:
        return list(ms)
    fb = get_method(fallback)
    if any(m.name == fb.name for m in ms):
        return list(ms)
    info["fallback"] = {"requested": [m.name for m in ms if m.needs_ndr], "ran": fb.name, "reasons": quality["reasons"]}
    out: list[Method] = []
    for m in ms:
        m2 = fb if m.needs_ndr else m
        if all(x.name != m2.name for x in out):
            out.append(m2)
    return out


@dataclass(frozen=True)
class Predicted:
    """Region and guideline for one plan: the model's, the oracle's or given arrays."""

    region_map: np.ndarray | None = None
    """Region at the map's resolution (report, figures, JSON)."""
    guideline_map: np.ndarray | None = None
    """Guideline at the map's resolution."""
    region: np.ndarray | None = None
    """Region on the planning grid (what the priors use)."""
    guideline: np.ndarray | None = None
    """Guideline on the planning grid."""
    weights: str | None = None
    """What made them: the weights file, ``"oracle priors"``, or ``None`` for given arrays."""


def predict_for(ms: Sequence[Method], predictions: tuple[np.ndarray, np.ndarray | None] | str | None,
                weights: str | os.PathLike | None, grid_map: GridMap, grid: PlanningGrid, start: Point, goal: Point,
                settings: PlanSettings, prior_config: PriorConfig, clock: StageClock,
                info: dict[str, Any]) -> tuple[Predicted, list[Method]]:
    """The predictions the NDR methods in ``ms`` need, and the methods to run after :func:`fall_back`.

    ``predictions``: ``None`` (the model in ``weights``, loaded once per process), ``"oracle"``
    (:func:`oracle_view`) or ``(region, guideline)`` at the map's resolution. Times the ``load`` and
    ``predict`` stages on ``clock``; records what the model saw in ``info``.
    """
    view = None
    used_weights = None
    if isinstance(predictions, str):
        if predictions != "oracle":
            raise NdrqlError(f"predictions must be (region, guideline) arrays or 'oracle', got {predictions!r}")
        with clock.stage("predict"):
            view = oracle_view(grid)
        info["model_input"] = view.info
        info["prior_from"] = "oracle"
        used_weights = ORACLE_NAME
        region_map, guideline_map = view.region, view.guideline
    elif predictions is not None:
        region_map, guideline_map = predictions
        for name, arr in (("region", region_map), ("guideline", guideline_map)):
            if arr is not None and np.shape(arr) != grid_map.shape:
                raise NdrqlError(f"{name} prediction is {np.shape(arr)[0]}x{np.shape(arr)[1]} but the map is "
                                 f"{grid_map.height}x{grid_map.width}; predictions must be at the map's resolution")
    else:
        with clock.stage("load"):
            predictor = load_predictor(weights, settings.threads, settings.backend)
        info["backend"] = predictor.backend_name
        used_weights = str(resolve_weights(weights))
        with clock.stage("predict"):
            view = predict_region(predictor, grid_map, grid, start, goal)
            info["model_input"] = view.info
            region_map, guideline_map = view.region, view.guideline
    needs_guide = [m.name for m in ms if m.needs_guideline]
    if guideline_map is None and needs_guide:
        raise NdrqlError(f"{', '.join(needs_guide)} need the guideline prediction, which "
                         f"{used_weights or 'the predictions'} do not provide (model without guideline decoder)")
    with clock.stage("predict"):
        if view is not None and view.region_grid is not None:  # predicted on the planning grid itself
            region, guideline = view.region_grid, view.guideline_grid
        else:
            region, guideline = downscale_priors(region_map, guideline_map, grid.shape)
        # the prediction's quality is judged with the given prior_config, whatever the preset
        ms = fall_back(ms, region, guideline_map, grid_map, grid, prior_config, settings.fallback, info)
    return Predicted(region_map, guideline_map, region, guideline, used_weights), list(ms)
