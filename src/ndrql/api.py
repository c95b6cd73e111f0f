"""The Python API of ndrql: plan a path on your own map with the pretrained NDR model.

    >>> import ndrql
    >>> result = ndrql.plan("map.png", start=(25, 179), goal=(167, 5))   # NDR-QL, seed 0
    >>> result.converged, result.path_length, result.length_ratio

:func:`plan` runs one method with one seed and returns a :class:`PlannedRun` (a
:class:`~ndrql.planning.results.PlanResult` with its path on the map and whether that path holds).
:func:`solve` runs several methods on the same seeds and returns a :class:`PlanReport` with the
planning grid, the model's predictions, the NDR-QI thresholds and the time of every stage; the
``ndrql plan`` and ``ndrql demo`` commands are thin wrappers around it.

The pipeline (:mod:`ndrql.pipeline`), as :func:`solve` reads top to bottom: read the map (image, ROS
``map_server`` YAML, MovingAI ``.map``, ``.npy``, or an array) -> place start and goal (on the map,
not on an obstacle pixel; ROS maps also take them in metres) -> inflate obstacles by the robot's
radius -> planning grid (on a user's map the safe grid: square cells, a cell blocked when any pixel is
an obstacle, at the coarsest size that keeps the route; :meth:`PlanSettings.paper` gives the paper's
50x50 area-averaged grid) -> the NDR model predicts region and guideline
(:func:`ndrql.pipeline.predictions.predict_for`), on the planning grid -> priors of each method
(Eqs. 2-7) -> Q-learning to convergence (Eq. 1) -> each learned path as a polyline on the full map,
checked for collisions, shortcut by line of sight, and as world poses (:mod:`ndrql.pipeline.route`).
The model is loaded once per process and reused (:func:`ndrql.model.predict.load_predictor`); torch
and numba are imported only when needed.

Bad input raises an :class:`~ndrql.errors.NdrqlError` subclass with a one-line message (the CLI
prints it and exits with 2).
"""

from __future__ import annotations

import os
from typing import Any, Sequence

import numpy as np

from ndrql.errors import NdrqlError, PointError  # noqa: F401 (NdrqlError: what bad input raises, for callers)
from ndrql.pipeline.predictions import GivenPredictions, Predicted, predict_for
from ndrql.pipeline.problem import build_grid, check_map_size, check_points, place_points, read_map, scenario_points
from ndrql.pipeline.report import STAGES, WORK_STAGES, PlannedRun, PlanReport, StageClock, planned_runs
from ndrql.pipeline.runs import check_workers, learn, method_priors, methods_named, seeds_given
from ndrql.pipeline.settings import PlanSettings
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.preset import load_preset, method_configs


def solve(
    map_or_path: Any,
    start: Sequence[int] | None = None,
    goal: Sequence[int] | None = None,
    methods: Sequence[str] | str = ("NDR-QL",),
    seeds: Sequence[int] | int = (0,),
    *,
    weights: str | os.PathLike | None = None,
    predictions: GivenPredictions | tuple[np.ndarray, np.ndarray | None] | str | None = None,
    config: QLConfig = QLConfig(),
    prior_config: PriorConfig = PriorConfig(),
    preset: Any = None,
    settings: PlanSettings = PlanSettings(),
    scen: str | os.PathLike | None = None,
    scen_index: int = 0,
    start_world: Sequence[float] | None = None,
    goal_world: Sequence[float] | None = None,
    invert: bool = False,
    threshold: float = 128,
    crop: bool = False,
    workers: int | None = None,
    keep_records: bool = False,
    info: dict[str, Any] | None = None,
    progress: bool = False,
) -> PlanReport:
    """Plan on one map with every method in ``methods`` and every seed in ``seeds``.

    ``map_or_path``: a map file (image, ROS ``.yaml``, MovingAI ``.map``, ``.npy``), a
    :class:`GridMap` or a 2-D array (non-zero = obstacle). ``start``/``goal``: ``(row, col)`` map
    pixels, or ``start_world``/``goal_world`` ``(x, y[, yaw])`` in metres on ROS maps (the yaws orient
    the first and last pose), or taken from MovingAI scenario ``scen_index`` of ``scen``.
    ``seeds``: a list, or an int ``N`` for seeds ``0..N-1``. ``weights``: model file (default:
    ``$NDRQL_WEIGHTS`` or the shipped weights); ``predictions``: ``(region, guideline)`` at the map's
    resolution instead of the model, a :class:`~ndrql.pipeline.predictions.GivenPredictions` (a file of
    ``ndrql predict``, :func:`~ndrql.pipeline.predictions.load_predictions`), or ``"oracle"`` for the oracle's (the planning grid's own shortest
    path drawn like the dataset's labels: a diagnostic of the ceiling, reported as "oracle priors"). ``settings``: grid rule, size, robot radius, smoothing
    (default: the safe grid for a user's map; :meth:`PlanSettings.paper` for the paper's).
    ``workers``: processes for many runs (default: all cores; results do not depend on it).
    ``preset``: ``"spec"``, ``"tuned"``, ``"general"``, a preset file or a
    :class:`~ndrql.planning.preset.Preset`: each method runs with its own constants from it (from a
    per-grid-size preset, those of the size nearest to the planning grid), and the fields of ``config``/``prior_config``
    that differ from their defaults win over the preset's (default ``None``: ``config`` and
    ``prior_config`` for every method, which by default are the paper-reproduction constants).
    """
    clock = StageClock()
    ms = methods_named(methods)
    seed_list = seeds_given(seeds)
    info = dict(info or {})
    preset_obj = None if preset is None else load_preset(preset)
    if preset_obj is not None:
        info["preset"] = preset_obj.name

    with clock.stage("map"):
        grid_map = read_map(map_or_path, invert=invert, threshold=threshold, crop=crop)
        info.setdefault("source", grid_map.source)
        check_map_size(grid_map, settings)
        start, goal, start_yaw, goal_yaw = place_points(grid_map, start, goal, scen=scen, scen_index=scen_index,
                                                        start_world=start_world, goal_world=goal_world, info=info)
    with clock.stage("grid"):
        pg, setup = build_grid(grid_map, start, goal, settings)
        if pg.start == pg.goal:
            raise PointError(f"start and goal fall in the same planning cell {pg.start}; nothing to plan "
                             f"(use a finer grid with --size or points further apart)")
    side = max(pg.blocked.shape)  # a per-grid-size preset takes the entry nearest to this grid
    consts = lambda name: method_configs(preset_obj, name, config, prior_config, side)  # noqa: E731
    pred = Predicted()
    if any(m.needs_ndr for m in ms):
        pred, ms = predict_for(ms, predictions, weights, grid_map, pg, start, goal, settings, prior_config, clock, info)
    with clock.stage("priors"):
        priors, thresholds = method_priors(ms, pg, pred.region, pred.guideline, consts, pred.distance)
    with clock.stage("startup"):
        from ndrql.planning import kernel  # lazy: loads numba

        kernel.warm_up()  # loads the compiled kernel from numba's disk cache (compiles on the very first run)
    n_workers = check_workers(workers)
    with clock.stage("learn"):
        results = learn(pg, ms, seed_list, consts, priors, pred.region, pred.guideline, n_workers, keep_records,
                        progress, pred.distance)
    with clock.stage("route"):
        runs = planned_runs(results, setup.check_map, pg, grid_map, settings.smoothing, start_yaw, goal_yaw)

    return PlanReport(
        grid_map=grid_map, start=start, goal=goal, grid=pg, methods=tuple(m.name for m in ms),
        seeds=tuple(seed_list), results=tuple(runs), region=pred.region_map, guideline=pred.guideline_map,
        thresholds=thresholds, timings=dict(clock.wall), cpu_times=dict(clock.cpu), weights=pred.weights,
        info=info, config=consts(ms[0].name)[0], prior_config=consts(ms[0].name)[1], setup=setup, settings=settings,
    )


def plan(
    map_or_path: Any,
    start: Sequence[int] | None = None,
    goal: Sequence[int] | None = None,
    method: str = "NDR-QL",
    seed: int = 0,
    **kwargs: Any,
) -> PlannedRun:
    """Plan a path with one method and one seed; returns the run (a :class:`PlanResult` with its route).

    ``map_or_path``: a map file (image, ROS ``.yaml``, MovingAI ``.map``, ``.npy``), a ``GridMap`` or
    a 2-D array (non-zero = obstacle); ``start``/``goal``: ``(row, col)`` map pixels. Keyword
    arguments are those of :func:`solve` (``weights``, ``settings``, ``start_world``, ``scen``, ...).
    ``result.path`` is in planning-grid cells; ``result.route`` is the path on the map (checked for
    collisions, shortcut, with world poses on ROS maps) and ``result.success`` says whether it holds.
    """
    return solve(map_or_path, start, goal, methods=(method,), seeds=(seed,), **kwargs).results[0]


def cell_path_to_pixels(report: PlanReport, path: Sequence[Sequence[int]]) -> list[tuple[float, float]]:
    """A planning-grid path as ``(row, col)`` map-pixel coordinates of the cell centres (pixel ``(r, c)``'s
    centre is ``(r, c)``; fractional values fall between pixels)."""
    return [report.grid.centre(c) for c in path]


__all__ = ["PlanReport", "PlanSettings", "PlannedRun", "STAGES", "WORK_STAGES", "plan", "solve", "read_map",
           "scenario_points", "check_points", "cell_path_to_pixels"]
