"""The Python API of ndrql: plan a path on your own map with the pretrained NDR model.

    >>> import ndrql
    >>> result = ndrql.plan("map.png", start=(25, 179), goal=(167, 5))   # NDR-QL, seed 0
    >>> result.converged, result.path_length, result.length_ratio

:func:`plan` runs one method with one seed and returns a :class:`PlannedRun` (a
:class:`~ndrql.planning.results.PlanResult` with its path on the map and whether that path holds).
:func:`solve` runs several methods on the same seeds and returns a :class:`PlanReport` with the
planning grid, the model's predictions, the NDR-QI thresholds and the time of every stage; the
``ndrql plan`` and ``ndrql demo`` commands are thin wrappers around it.

The pipeline (:mod:`ndrql.pipeline`): read the map (image, ROS ``map_server`` YAML, MovingAI
``.map``, ``.npy``, or an array) -> check start and goal (on the map, not on an obstacle pixel; ROS
maps also take them in metres) -> inflate obstacles by the robot's radius -> planning grid (on a
user's map the safe grid: square cells, a cell blocked when any pixel is an obstacle, at the coarsest
size that keeps the route; :meth:`PlanSettings.paper` gives the paper's 50x50 area-averaged grid) ->
the NDR model predicts region and guideline at the map's resolution
(:func:`ndrql.pipeline.predictions.predict_region`) -> area-averaged to the planning grid -> priors
of each method (Eqs. 2-7) -> Q-learning to convergence (Eq. 1) -> each learned path as a polyline on
the full map, checked for collisions, shortcut by line of sight, and as world poses
(:mod:`ndrql.pipeline.route`). The model is loaded once per process and reused
(:func:`ndrql.model.predict.load_predictor`); torch and numba are imported only when needed.

Bad input raises an :class:`~ndrql.errors.NdrqlError` subclass with a one-line message (the CLI
prints it and exits with 2).
"""

from __future__ import annotations

import dataclasses
import os
import time
import warnings
from contextlib import contextmanager
from typing import Any, Iterator, Sequence

import numpy as np

from ndrql.errors import NdrqlError, PointError
from ndrql.maps.grid import GridMap, PlanningGrid
from ndrql.maps.world import world_to_pixel
from ndrql.model.predict import load_predictor
from ndrql.model.weights import resolve_weights
from ndrql.pipeline.predictions import oracle_view, predict_region, prediction_quality
from ndrql.pipeline.problem import build_grid, check_map_size, check_points, read_map, scenario_points
from ndrql.pipeline.report import STAGES, WORK_STAGES, PlannedRun, PlanReport
from ndrql.pipeline.route import Route, make_route
from ndrql.pipeline.settings import PlanSettings
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import build_priors, downscale_priors, get_method
from ndrql.planning.preset import load_preset, method_configs
from ndrql.planning.runner import PlanJob, default_workers, plan as run_one, run_many

Point = tuple[int, int]

# ------------------------------------------------------------------------------------------ helpers


class _Clock:
    """Wall and CPU time per named stage (accumulating)."""

    def __init__(self) -> None:
        self.wall: dict[str, float] = {s: 0.0 for s in STAGES}
        self.cpu: dict[str, float] = {s: 0.0 for s in STAGES}

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        w, c = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            self.wall[name] += time.perf_counter() - w
            self.cpu[name] += time.process_time() - c


def _world_point(grid_map: GridMap, given: Sequence[float] | None, name: str) -> tuple[Point | None, float | None]:
    """A ``(x, y[, yaw])`` world point (metres) as a map pixel and its yaw."""
    if given is None:
        return None, None
    vals = [float(v) for v in given]
    if len(vals) not in (2, 3):
        raise PointError(f"{name} must be (x, y) or (x, y, yaw) in metres and radians, got {tuple(given)!r}")
    return world_to_pixel(grid_map, vals[0], vals[1], name), (vals[2] if len(vals) == 3 else None)


def _fall_back(ms: list, region: np.ndarray, guideline_map: np.ndarray | None, grid_map: GridMap, pg: PlanningGrid,
               prior_config: PriorConfig, settings: PlanSettings, info: dict[str, Any]) -> list:
    """Judge the prediction (``info["prediction_quality"]``); when it is uninformative and ``settings.fallback``
    is set, each NDR method is replaced by the fallback (``info["fallback"]``), unless that one runs anyway."""
    quality = prediction_quality(region, guideline_map, grid_map.obstacles, pg, prior_config)
    info["prediction_quality"] = quality
    if quality["informative"] or settings.fallback is None:
        return ms
    fb = get_method(settings.fallback)
    if any(m.name == fb.name for m in ms):
        return ms
    info["fallback"] = {"requested": [m.name for m in ms if m.needs_ndr], "ran": fb.name, "reasons": quality["reasons"]}
    out = []
    for m in ms:
        m2 = fb if m.needs_ndr else m
        if all(x.name != m2.name for x in out):
            out.append(m2)
    return out


# --------------------------------------------------------------------------------------------- API


def solve(
    map_or_path: Any,
    start: Sequence[int] | None = None,
    goal: Sequence[int] | None = None,
    methods: Sequence[str] | str = ("NDR-QL",),
    seeds: Sequence[int] | int = (0,),
    *,
    weights: str | os.PathLike | None = None,
    predictions: tuple[np.ndarray, np.ndarray | None] | str | None = None,
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
    resolution instead of the model, or ``"oracle"`` for the oracle's (the planning grid's own shortest
    path drawn like the dataset's labels: a diagnostic of the ceiling, reported as "oracle priors"). ``settings``: grid rule, size, robot radius, smoothing
    (default: the safe grid for a user's map; :meth:`PlanSettings.paper` for the paper's).
    ``workers``: processes for many runs (default: all cores; results do not depend on it).
    ``preset``: ``"spec"``, ``"tuned"``, a preset file or a :class:`~ndrql.planning.preset.Preset`:
    each method runs with its own constants from it, and the fields of ``config``/``prior_config``
    that differ from their defaults win over the preset's (default ``None``: ``config`` and
    ``prior_config`` for every method, which by default are the paper-reproduction constants).
    """
    clock = _Clock()
    names = [methods] if isinstance(methods, str) else list(methods)
    ms = [get_method(n.strip() if isinstance(n, str) else n) for n in names]
    if not ms:
        raise NdrqlError("no method given")
    if len({m.name for m in ms}) != len(ms):
        raise NdrqlError(f"a method is listed twice: {', '.join(m.name for m in ms)}")
    seed_list = list(range(int(seeds))) if isinstance(seeds, (int, np.integer)) else [int(s) for s in seeds]
    if not seed_list:
        raise NdrqlError("no seed given")
    info = dict(info or {})
    preset_obj = None if preset is None else load_preset(preset)
    consts = lambda name: method_configs(preset_obj, name, config, prior_config)  # noqa: E731
    if preset_obj is not None:
        info["preset"] = preset_obj.name

    with clock.stage("map"):
        grid_map = read_map(map_or_path, invert=invert, threshold=threshold, crop=crop)
        info.setdefault("source", grid_map.source)
        check_map_size(grid_map, settings)
        if scen is not None:
            s_start, s_goal, s_info = scenario_points(scen, scen_index, grid_map)
            start = start if start is not None else s_start
            goal = goal if goal is not None else s_goal
            info.update(s_info)
        w_start, start_yaw = _world_point(grid_map, start_world, "start")
        w_goal, goal_yaw = _world_point(grid_map, goal_world, "goal")
        for name, px, w in (("start", start, w_start), ("goal", goal, w_goal)):
            if px is not None and w is not None:
                raise PointError(f"give the {name} in pixels or in world coordinates, not both")
        start = w_start if w_start is not None else start
        goal = w_goal if w_goal is not None else goal
        start, goal = check_points(grid_map, start, goal)  # type: ignore[arg-type]
    with clock.stage("grid"):
        pg, setup = build_grid(grid_map, start, goal, settings)
        if pg.start == pg.goal:
            raise PointError(f"start and goal fall in the same planning cell {pg.start}; nothing to plan "
                             f"(use a finer grid with --size or points further apart)")

    region_map = guideline_map = region = guideline = None
    used_weights = None
    view = None
    if any(m.needs_ndr for m in ms):
        if isinstance(predictions, str):
            if predictions != "oracle":
                raise NdrqlError(f"predictions must be (region, guideline) arrays or 'oracle', got {predictions!r}")

            with clock.stage("predict"):
                view = oracle_view(pg)
            info["model_input"] = view.info
            info["prior_from"] = "oracle"
            used_weights = "oracle priors"
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
                view = predict_region(predictor, grid_map, pg, start, goal)
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
                region, guideline = downscale_priors(region_map, guideline_map, pg.shape)
            # the prediction's quality is judged with the given prior_config, whatever the preset
            ms = _fall_back(ms, region, guideline_map, grid_map, pg, prior_config, settings, info)

    priors = {}
    thresholds: dict[str, float | None] = {}
    with clock.stage("priors"):
        for m in ms:
            priors[m.name] = build_priors(m, pg.blocked, pg.start, pg.goal, region, guideline, consts(m.name)[1])
            if m.n_qi:
                thresholds[m.name] = priors[m.name].threshold

    with clock.stage("startup"):
        from ndrql.planning import kernel  # lazy: loads numba

        kernel.warm_up()  # loads the compiled kernel from numba's disk cache (compiles on the very first run)

    jobs = [(m, s) for m in ms for s in seed_list]
    n_workers = default_workers() if workers is None else int(workers)
    if n_workers < 1:
        raise NdrqlError(f"workers must be >= 1, got {workers}")
    with clock.stage("learn"), warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # NDR-QI warnings were raised once while building priors
        if n_workers == 1 or len(jobs) == 1:
            from tqdm import tqdm  # progress: a bar of finished runs on stderr, on a terminal only

            results = [run_one(pg.blocked, pg.start, pg.goal, m.name, s, *consts(m.name),
                               priors=priors[m.name], keep_records=keep_records)
                       for m, s in tqdm(jobs, desc="runs", unit="run", disable=None if progress else True, leave=False)]
        else:
            results = run_many([PlanJob(pg.blocked, pg.start, pg.goal, m.name, s, *consts(m.name), region, guideline,
                                        keep_records) for m, s in jobs], workers=n_workers, progress=progress)

    with clock.stage("route"):
        routes: dict[tuple[tuple[int, int], ...], Route] = {}  # seeds often agree on the path: check it once
        runs = []
        for r in results:
            route = None
            if r.path:
                key = tuple((int(a), int(b)) for a, b in r.path)
                if key not in routes:
                    routes[key] = make_route(setup.check_map, pg, r.path, grid_map, smooth=settings.smoothing,
                                             start_yaw=start_yaw, goal_yaw=goal_yaw)
                route = routes[key]
            fields = {f.name: getattr(r, f.name) for f in dataclasses.fields(r)}
            runs.append(PlannedRun(**fields, route=route))

    return PlanReport(
        grid_map=grid_map, start=start, goal=goal, grid=pg, methods=tuple(m.name for m in ms),
        seeds=tuple(seed_list), results=tuple(runs), region=region_map, guideline=guideline_map,
        thresholds=thresholds, timings=dict(clock.wall), cpu_times=dict(clock.cpu), weights=used_weights,
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
