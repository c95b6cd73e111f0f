"""The Python API of ndrql: plan a path on your own map with the pretrained NDR model.

    >>> import ndrql
    >>> result = ndrql.plan("map.png", start=(25, 179), goal=(167, 5))   # NDR-QL, seed 0
    >>> result.converged, result.path_length, result.length_ratio

:func:`plan` runs one method with one seed and returns a :class:`~ndrql.planning.results.PlanResult`.
:func:`solve` runs several methods on the same seeds and returns a :class:`PlanReport` with the
planning grid, the model's predictions, the NDR-QI thresholds and the time of every stage; the
``ndrql plan`` and ``ndrql demo`` commands are thin wrappers around it.

The pipeline (SPEC sections 1-4): read the map (image, ROS ``map_server`` YAML, MovingAI ``.map``,
``.npy``, or an array) -> check start and goal (on the map, not on an obstacle pixel) -> planning
grid (50x50 by area averaging; a point whose cell is blocked moves to the nearest free cell with a
warning; start and goal must be 4-connected) -> the NDR model predicts region and guideline at the
map's resolution (any size: :mod:`ndrql.model.predict` resizes the longer side to 201 and pads with
obstacles) -> area-averaged to the planning grid -> priors of each method (Eqs. 2-7) -> Q-learning
to convergence (Eq. 1). The model is loaded once per process and reused
(:func:`ndrql.planning.methods.load_predictor`); torch and numba are imported only when needed.

Bad input raises an :class:`~ndrql.errors.NdrqlError` subclass with a one-line message (the CLI
prints it and exits with 2).
"""

from __future__ import annotations

import dataclasses
import os
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, Iterator, Sequence

import numpy as np

from ndrql.errors import MapFormatError, NdrqlError, PointError
from ndrql.maps.grid import GridMap, PlanningGrid
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.results import PlanResult

Point = tuple[int, int]

#: Stages timed by :func:`solve`, in order. ``startup`` is per-process (numba kernel load from its
#: disk cache); ``load`` is the model's, once per process (with the torch import on the torch backend
#: or when ONNX Runtime's export is not cached yet); the others are the work done for one map.
STAGES: tuple[str, ...] = ("startup", "map", "load", "predict", "priors", "learn")
#: The stages that make up the work for one map after start-up (the 0.5 s budget of issue 6).
WORK_STAGES: tuple[str, ...] = ("load", "predict", "priors", "learn")


@dataclass(frozen=True)
class PlanSettings:
    """How a map becomes a planning problem (SPEC section 1), and the limits that guard it."""

    size: int = 50
    """Side of the planning grid in cells (paper: 201 px -> 50 cells)."""
    max_map_pixels: int = 4096 * 4096
    """Largest map accepted, in pixels; larger maps are refused (crop or downscale them first)."""
    max_size: int = 256
    """Largest planning grid side accepted (the Q-table and episode caps grow with its square)."""
    threads: int = 1
    """Threads for the model's forward pass (1: about as fast as 2 for one map, and much faster on a busy machine)."""
    backend: str = "auto"
    """Model inference backend: auto (ONNX Runtime when installed, else torch), onnx or torch."""

    def __post_init__(self) -> None:
        if self.size < 2:
            raise NdrqlError(f"the planning grid size must be at least 2, got {self.size}")
        if self.size > self.max_size:
            raise NdrqlError(f"the planning grid size {self.size} is larger than the limit {self.max_size}")
        if self.max_map_pixels < 1:
            raise NdrqlError(f"max_map_pixels must be positive, got {self.max_map_pixels}")
        from ndrql.model.predict import BACKENDS

        if self.backend not in BACKENDS:
            raise NdrqlError(f"unknown inference backend {self.backend!r}; valid: {', '.join(BACKENDS)}")


@dataclass(frozen=True)
class PlanReport:
    """Everything :func:`solve` computed: problem, predictions, runs and timings."""

    grid_map: GridMap
    """The map as read (``True`` = obstacle)."""
    start: Point
    """Start in map pixels ``(row, col)``."""
    goal: Point
    """Goal in map pixels ``(row, col)``."""
    grid: PlanningGrid
    """The planning grid with start and goal cells (snapped, connected)."""
    methods: tuple[str, ...]
    """Method names, in run order."""
    seeds: tuple[int, ...]
    """Seeds, the same for every method."""
    results: tuple[PlanResult, ...]
    """One result per (method, seed), methods outer."""
    region: np.ndarray | None
    """NDR region probabilities at the map's resolution (``None`` if no method needed the model)."""
    guideline: np.ndarray | None
    """NDR guideline probabilities at the map's resolution (``None`` as above, or no guideline decoder)."""
    thresholds: dict[str, float | None]
    """NDR-QI threshold (Eq. 7) per method that uses it; ``None`` = none connected, mask 0 everywhere."""
    timings: dict[str, float]
    """Wall-clock seconds per stage (:data:`STAGES`)."""
    cpu_times: dict[str, float]
    """CPU seconds of this process per stage (learning in worker processes is not included)."""
    weights: str | None
    """Model weights used (``None`` without the model or with given predictions)."""
    info: dict[str, Any] = field(default_factory=dict)
    """Where the problem came from (map file, dataset sample, MovingAI scenario)."""
    config: QLConfig = QLConfig()
    """Q-learning settings the runs used."""
    prior_config: PriorConfig = PriorConfig()
    """Prior settings the runs used."""

    @property
    def astar_length(self) -> int:
        """Optimal 4-connected path length on the planning grid."""
        return self.results[0].astar_length

    @property
    def work_time(self) -> float:
        """Wall seconds of load + predict + priors + learn."""
        return sum(self.timings.get(s, 0.0) for s in WORK_STAGES)

    def runs(self, method: str) -> list[PlanResult]:
        """The results of one method, in seed order."""
        return [r for r in self.results if r.method == method]

    def _run_dict(self, r: PlanResult, include_records: bool) -> dict[str, Any]:
        out = r.to_dict(include_records=include_records)
        if r.path:
            px = cell_path_to_pixels(self, r.path)
            out["path_pixels"] = [[round(a, 3), round(b, 3)] for a, b in px]
            world = pixels_to_world(self.grid_map, px)
            if world is not None:
                out["path_world"] = [[round(x, 4), round(y, 4)] for x, y in world]
        return out

    def to_dict(self, include_records: bool = False) -> dict[str, Any]:
        """The JSON form written by ``ndrql plan --json`` (plain types only)."""
        from ndrql.planning.results import summarize

        gm = self.grid_map
        map_info: dict[str, Any] = {"source": gm.source, "height": gm.height, "width": gm.width,
                                    "obstacle_ratio": round(gm.obstacle_ratio, 6)}
        if gm.resolution is not None:
            map_info["resolution"] = gm.resolution
        if gm.origin is not None:
            map_info["origin"] = list(gm.origin)
        pg = self.grid
        first = self.results[0]
        return {
            "map": map_info,
            **{k: v for k, v in self.info.items() if k != "source"},
            "planning_size": list(pg.shape),
            "grid": pg.to_strings(),
            "start": list(pg.start),
            "goal": list(pg.goal),
            "source_start": list(pg.source_start),
            "source_goal": list(pg.source_goal),
            "snapped": {"start": pg.snapped[0], "goal": pg.snapped[1]},
            "astar_length": self.astar_length,
            "methods": list(self.methods),
            "seeds": list(self.seeds),
            "config": dataclasses.asdict(self.config),
            "prior_config": dataclasses.asdict(self.prior_config),
            "weights": self.weights,
            "prior_from": self.info.get("prior_from"),
            "ndr_qi_threshold": dict(self.thresholds),
            "timings": {"wall": dict(self.timings), "cpu": dict(self.cpu_times), "work_wall": self.work_time},
            "summary": {
                m: {
                    "runs": len(self.runs(m)),
                    "not_converged": sum(not r.converged for r in self.runs(m)),
                    "convergence_steps": summarize([r.convergence_steps for r in self.runs(m) if r.converged]),
                    "convergence_episode": summarize([r.convergence_episode for r in self.runs(m) if r.converged]),
                    "length_ratio": summarize([r.length_ratio for r in self.runs(m) if r.converged]),
                }
                for m in self.methods
            },
            "runs": [self._run_dict(r, include_records) for r in self.results],
            "first": {"method": first.method, "seed": first.seed},
        }


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


def read_map(map_or_path: Any, *, invert: bool = False, threshold: float = 128, crop: bool = False) -> GridMap:
    """A :class:`GridMap` from a path (any supported format), a ``GridMap`` or a 2-D array (non-zero = obstacle)."""
    if isinstance(map_or_path, GridMap):
        return map_or_path
    if isinstance(map_or_path, np.ndarray):
        if map_or_path.ndim != 2 or map_or_path.size == 0:
            raise MapFormatError(f"a map array must be non-empty and 2-D, got shape {map_or_path.shape}")
        return GridMap(map_or_path != 0, source="array")
    if isinstance(map_or_path, (str, os.PathLike)):
        from ndrql.maps.readers import load_map

        return load_map(map_or_path, invert=invert, threshold=threshold, crop=crop)
    raise MapFormatError(f"cannot read a map from {type(map_or_path).__name__}; pass a file path, a GridMap or a 2-D array")


def scenario_points(scen: str | os.PathLike, index: int, grid_map: GridMap) -> tuple[Point, Point, dict[str, Any]]:
    """Start and goal ``(row, col)`` of scenario ``index`` in a MovingAI ``.scen`` file, checked against the map."""
    from ndrql.maps.readers import read_movingai_scen

    scenarios = read_movingai_scen(scen)
    if not 0 <= index < len(scenarios):
        raise MapFormatError(f"scenario {index} not in {scen} (it has {len(scenarios)} scenarios, 0..{len(scenarios) - 1})")
    s = scenarios[index]
    if grid_map.shape != (s.height, s.width):
        raise MapFormatError(f"scenario {index} of {scen} is for a {s.width}x{s.height} map (width x height), "
                             f"the map is {grid_map.width}x{grid_map.height}")
    info = {"scenario": {"file": str(scen), "index": index, "optimal_length": s.optimal_length}}
    return (int(s.start[0]), int(s.start[1])), (int(s.goal[0]), int(s.goal[1])), info


def check_points(grid_map: GridMap, start: Sequence[int], goal: Sequence[int]) -> tuple[Point, Point]:
    """``start``/``goal`` as ``(row, col)`` ints, on the map and on free pixels; :class:`PointError` otherwise."""
    h, w = grid_map.shape
    out = []
    for name, p in (("start", start), ("goal", goal)):
        if p is None:
            raise PointError(f"no {name} given (ROW,COL in map pixels)")
        try:
            r, c = (int(v) for v in p)
        except (TypeError, ValueError):
            raise PointError(f"{name} must be (row, col), got {p!r}") from None
        if not (0 <= r < h and 0 <= c < w):
            raise PointError(f"{name} {r},{c} is outside the map (rows 0..{h - 1}, cols 0..{w - 1})")
        if grid_map.obstacles[r, c]:
            raise PointError(f"{name} {r},{c} is on an obstacle of the map")
        out.append((r, c))
    return out[0], out[1]


def check_map_size(grid_map: GridMap, settings: PlanSettings) -> None:
    """Refuse maps larger than ``settings.max_map_pixels`` (they cost memory and time for nothing)."""
    if grid_map.height * grid_map.width > settings.max_map_pixels:
        raise MapFormatError(
            f"map is {grid_map.height}x{grid_map.width} = {grid_map.height * grid_map.width:,} pixels, more than the "
            f"limit of {settings.max_map_pixels:,} for a {settings.size}x{settings.size} planning grid; crop or "
            f"downscale it, or raise --max-pixels"
        )


def model_input_points(obstacles: np.ndarray, start: Point, goal: Point) -> dict[str, Any]:
    """Where start and goal land in the model's 201x201 input (:func:`ndrql.model.predict.to_model_input`).

    A map that is not 201x201 is resized and padded for the model; a point whose resized pixel is an
    obstacle is moved to the nearest free pixel there. That is reported with a warning (the model
    then sees the point somewhere else; planning still uses the exact point).
    """
    from ndrql.model.predict import MODEL_SIDE, point_on_grid, to_model_input

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


# --------------------------------------------------------------------------------------------- API


def solve(
    map_or_path: Any,
    start: Sequence[int] | None = None,
    goal: Sequence[int] | None = None,
    methods: Sequence[str] | str = ("NDR-QL",),
    seeds: Sequence[int] | int = (0,),
    *,
    weights: str | os.PathLike | None = None,
    predictions: tuple[np.ndarray, np.ndarray | None] | None = None,
    config: QLConfig = QLConfig(),
    prior_config: PriorConfig = PriorConfig(),
    settings: PlanSettings = PlanSettings(),
    scen: str | os.PathLike | None = None,
    scen_index: int = 0,
    invert: bool = False,
    threshold: float = 128,
    crop: bool = False,
    workers: int | None = None,
    keep_records: bool = False,
    info: dict[str, Any] | None = None,
) -> PlanReport:
    """Plan on one map with every method in ``methods`` and every seed in ``seeds``.

    ``map_or_path``: a map file (image, ROS ``.yaml``, MovingAI ``.map``, ``.npy``), a
    :class:`GridMap` or a 2-D array (non-zero = obstacle). ``start``/``goal``: ``(row, col)`` map
    pixels, or taken from MovingAI scenario ``scen_index`` of ``scen``. ``seeds``: a list, or an int
    ``N`` for seeds ``0..N-1``. ``weights``: model file (default: ``$NDRQL_WEIGHTS`` or the shipped
    weights); ``predictions``: ``(region, guideline)`` at the map's resolution instead of the model.
    ``workers``: processes for many runs (default: all cores; results do not depend on it).
    """
    from ndrql.planning.methods import build_priors, downscale_priors, get_method

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

    with clock.stage("map"):
        grid_map = read_map(map_or_path, invert=invert, threshold=threshold, crop=crop)
        info.setdefault("source", grid_map.source)
        check_map_size(grid_map, settings)
        if scen is not None:
            s_start, s_goal, s_info = scenario_points(scen, scen_index, grid_map)
            start = start if start is not None else s_start
            goal = goal if goal is not None else s_goal
            info.update(s_info)
        start, goal = check_points(grid_map, start, goal)  # type: ignore[arg-type]
        pg = PlanningGrid.from_map(grid_map, start, goal, size=settings.size)
        if pg.start == pg.goal:
            raise PointError(f"start and goal fall in the same planning cell {pg.start}; nothing to plan "
                             f"(use a finer grid with --size or points further apart)")

    region_map = guideline_map = region = guideline = None
    used_weights = None
    if any(m.needs_ndr for m in ms):
        if predictions is not None:
            region_map, guideline_map = predictions
            for name, arr in (("region", region_map), ("guideline", guideline_map)):
                if arr is not None and np.shape(arr) != grid_map.shape:
                    raise NdrqlError(f"{name} prediction is {np.shape(arr)[0]}x{np.shape(arr)[1]} but the map is "
                                     f"{grid_map.height}x{grid_map.width}; predictions must be at the map's resolution")
        else:
            from ndrql.model.predict import default_weights_path
            from ndrql.planning.methods import load_predictor

            with clock.stage("load"):
                predictor = load_predictor(weights, settings.threads, settings.backend)
            info["backend"] = predictor.backend_name
            used_weights = str(weights if weights is not None else default_weights_path())
            with clock.stage("predict"):
                info["model_input"] = model_input_points(grid_map.obstacles, start, goal)
                pred = predictor.predict(grid_map.obstacles, start, goal)
                region_map = np.asarray(pred.region, dtype=np.float64)
                guideline_map = None if pred.guideline is None else np.asarray(pred.guideline, dtype=np.float64)
        needs_guide = [m.name for m in ms if m.needs_guideline]
        if guideline_map is None and needs_guide:
            raise NdrqlError(f"{', '.join(needs_guide)} need the guideline prediction, which "
                             f"{used_weights or 'the predictions'} do not provide (model without guideline decoder)")
        with clock.stage("predict"):
            region, guideline = downscale_priors(region_map, guideline_map, pg.shape)

    priors = {}
    thresholds: dict[str, float | None] = {}
    with clock.stage("priors"):
        for m in ms:
            priors[m.name] = build_priors(m, pg.blocked, pg.start, pg.goal, region, guideline, prior_config)
            if m.n_qi:
                thresholds[m.name] = priors[m.name].threshold

    with clock.stage("startup"):
        from ndrql.planning import kernel

        kernel.warm_up()  # loads the compiled kernel from numba's disk cache (compiles on the very first run)
    from ndrql.planning.runner import PlanJob, default_workers, plan as run_one, run_many

    jobs = [(m, s) for m in ms for s in seed_list]
    n_workers = default_workers() if workers is None else int(workers)
    if n_workers < 1:
        raise NdrqlError(f"workers must be >= 1, got {workers}")
    with clock.stage("learn"), warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # NDR-QI warnings were raised once while building priors
        if n_workers == 1 or len(jobs) == 1:
            results = [run_one(pg.blocked, pg.start, pg.goal, m.name, s, config, prior_config,
                               priors=priors[m.name], keep_records=keep_records) for m, s in jobs]
        else:
            results = run_many([PlanJob(pg.blocked, pg.start, pg.goal, m.name, s, config, prior_config, region, guideline,
                                        keep_records) for m, s in jobs], workers=n_workers)

    return PlanReport(
        grid_map=grid_map, start=start, goal=goal, grid=pg, methods=tuple(m.name for m in ms),
        seeds=tuple(seed_list), results=tuple(results), region=region_map, guideline=guideline_map,
        thresholds=thresholds, timings=dict(clock.wall), cpu_times=dict(clock.cpu), weights=used_weights,
        info=info, config=config, prior_config=prior_config,
    )


def plan(
    map_or_path: Any,
    start: Sequence[int] | None = None,
    goal: Sequence[int] | None = None,
    method: str = "NDR-QL",
    seed: int = 0,
    **kwargs: Any,
) -> PlanResult:
    """Plan a path with one method and one seed; returns the run's :class:`PlanResult`.

    ``map_or_path``: a map file (image, ROS ``.yaml``, MovingAI ``.map``, ``.npy``), a ``GridMap`` or
    a 2-D array (non-zero = obstacle); ``start``/``goal``: ``(row, col)`` map pixels. Keyword
    arguments are those of :func:`solve` (``weights``, ``config``, ``prior_config``, ``settings``,
    ``scen``/``scen_index``, ...). ``result.path`` is in planning-grid cells; see :func:`solve` for
    the grid, predictions and timings.
    """
    return solve(map_or_path, start, goal, methods=(method,), seeds=(seed,), **kwargs).results[0]


def cell_path_to_pixels(report: PlanReport, path: Sequence[Sequence[int]]) -> list[tuple[float, float]]:
    """A planning-grid path as ``(row, col)`` map-pixel coordinates of the cell centres (pixel ``(r, c)``'s
    centre is ``(r, c)``; fractional values fall between pixels)."""
    from ndrql.maps.grid import cell_to_point

    return [cell_to_point(c, report.grid_map.shape, report.grid.shape) for c in path]


def pixels_to_world(grid_map: GridMap, points: Sequence[Sequence[float]]) -> list[tuple[float, float]] | None:
    """ROS ``map_server`` world coordinates ``(x, y)`` in metres of ``(row, col)`` pixel points.

    ``origin = (x0, y0, yaw)`` is the pose of the lower-left corner of the image (row ``H - 1`` is the
    bottom), ``resolution`` metres per pixel. ``None`` for maps without resolution and origin.
    """
    import math

    if grid_map.resolution is None or grid_map.origin is None:
        return None
    res = float(grid_map.resolution)
    x0, y0 = grid_map.origin[0], grid_map.origin[1]
    yaw = grid_map.origin[2] if len(grid_map.origin) > 2 else 0.0
    cy, sy = math.cos(yaw), math.sin(yaw)
    h = grid_map.height
    out = []
    for r, c in points:
        dx, dy = (c + 0.5) * res, (h - (r + 0.5)) * res
        out.append((x0 + cy * dx - sy * dy, y0 + sy * dx + cy * dy))
    return out


__all__ = ["PlanReport", "PlanSettings", "STAGES", "WORK_STAGES", "plan", "solve", "read_map", "scenario_points",
           "check_points", "cell_path_to_pixels", "pixels_to_world"]
