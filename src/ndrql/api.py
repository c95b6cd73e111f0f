"""The Python API of ndrql: plan a path on your own map with the pretrained NDR model.

    >>> import ndrql
    >>> result = ndrql.plan("map.png", start=(25, 179), goal=(167, 5))   # NDR-QL, seed 0
    >>> result.converged, result.path_length, result.length_ratio

:func:`plan` runs one method with one seed and returns a :class:`PlannedRun` (a
:class:`~ndrql.planning.results.PlanResult` with its path on the map and whether that path holds).
:func:`solve` runs several methods on the same seeds and returns a :class:`PlanReport` with the
planning grid, the model's predictions, the NDR-QI thresholds and the time of every stage. Both
take a :class:`PlanRequest` or build one with :func:`build_request`, the one place a plan's defaults
are decided and its input checked; ``ndrql plan``, its scenario batch and ``ndrql demo`` turn their
flags into the same request, so the CLI and the API give the same plan for the same request.

The pipeline (:mod:`ndrql.pipeline`), as :func:`run_request` reads top to bottom: read the map (image, ROS
``map_server`` YAML, MovingAI ``.map``, ``.npy``, or an array) -> place start and goal (on the map,
not on an obstacle pixel; ROS maps also take them in metres) -> inflate obstacles by the robot's
radius -> planning grid (on a user's map the safe grid: square cells, a cell blocked when any pixel is
an obstacle, at the coarsest size that keeps the route; :meth:`PlanSettings.paper` gives the paper's
50x50 area-averaged grid) -> the NDR model predicts region and guideline
(:func:`ndrql.pipeline.prior_stage.predict_for`: its sources under a time budget, one judge, IQL-BFS where
every source is rejected), on the planning grid -> priors of each method
(Eqs. 2-7) -> Q-learning to convergence (Eq. 1) -> each learned path as a polyline on the full map,
checked for collisions, shortcut by line of sight, and as world poses (:mod:`ndrql.pipeline.route`).
The model is loaded once per process and reused (:func:`ndrql.model.predict.load_predictor`); torch
and numba are imported only when needed.

Bad input raises an :class:`~ndrql.errors.NdrqlError` subclass with a one-line message (the CLI
prints it and exits with 2).
"""

from __future__ import annotations

import functools
import inspect
import sys
from typing import Any, Callable, Sequence, TypeVar

from ndrql.errors import ArgumentError, FallbackWarning, NdrqlError, NdrqlWarning, PointError  # noqa: F401 (what callers catch and filter)
from ndrql.pipeline.fallback import warn_fallbacks
from ndrql.pipeline.predictions import GivenPredictions, load_predictions
from ndrql.pipeline.prior_stage import Predicted, predict_for
from ndrql.pipeline.belief import belief_record, plan_grids
from ndrql.pipeline.sensing import learn_sensed
from ndrql.pipeline.problem import check_points, read_map, scenario_points
from ndrql.pipeline.report import STAGES, WORK_STAGES, PlannedRun, PlanReport, StageClock, planned_runs
from ndrql.pipeline.request import PlanRequest, build_request
from ndrql.pipeline.runs import check_workers, learn, method_priors, qi_distance
from ndrql.pipeline.settings import DEFAULT_PREDICT_BUDGET, PlanSettings
from ndrql.pipeline.shortest import AStarRun, search
from ndrql.planning import compiled
from ndrql.planning.methods import get_method

#: Positional arguments of :func:`solve` after the map (the keyword form), in order.
SOLVE_POSITIONAL = ("start", "goal", "methods", "seeds")
#: Positional arguments of :func:`plan` after the map.
PLAN_POSITIONAL = ("start", "goal", "method", "seed")


_F = TypeVar("_F", bound=Callable[..., Any])


def _named_arguments(fn: _F) -> _F:
    """An API function whose wrong arguments (an unknown keyword, one given twice, too many) are an
    :class:`NdrqlError` naming them, like every other bad input, not Python's ``TypeError``."""
    sig = inspect.signature(fn)

    @functools.wraps(fn)
    def checked(*args: Any, **kwargs: Any) -> Any:
        try:
            sig.bind(*args, **kwargs)
        except TypeError as exc:
            raise ArgumentError(f"{fn.__name__}(): {exc}") from None
        return fn(*args, **kwargs)

    return checked  # type: ignore[return-value]


def _request(map_or_request: Any, positional: Sequence[Any], names: Sequence[str], fields: dict[str, Any]) -> PlanRequest:
    """The request given, or one built from the keyword form by :func:`build_request` (the one builder)."""
    if isinstance(map_or_request, PlanRequest):
        if positional or fields:
            raise NdrqlError("a PlanRequest is the whole plan: change it with build_request, not with more arguments")
        return map_or_request
    if len(positional) > len(names):
        raise NdrqlError(f"too many positional arguments: after the map, at most {', '.join(names)}")
    for name, value in zip(names, positional):
        if name in fields:
            raise NdrqlError(f"{name} given twice")
        fields[name] = value
    return build_request(map_or_request, **fields)


def run_request(request: PlanRequest, *, workers: int | None = None, keep_records: bool = False,
                progress: bool = False, _caller: int = 1) -> PlanReport:
    """Plan ``request``: every method with every seed (:func:`solve` reads as this function). A method the
    fallback replaced issues a :class:`~ndrql.errors.FallbackWarning` at the caller's line."""
    clock = StageClock(sys.stderr if progress and sys.stderr.isatty() else None)  # long stages shown on a terminal
    clock.wall["map"] = clock.cpu["map"] = request.map_seconds
    with clock.stage("grid"):
        pg, setup = plan_grids(request.grid_map, request.start, request.goal, request.settings, request.belief)
        if pg.start == pg.goal:
            raise PointError(f"start and goal fall in the same planning cell {pg.start}; nothing to plan "
                             f"(use a finer grid with --size or points further apart)")
    side = max(pg.blocked.shape)  # a per-grid-size preset takes the entry nearest to this grid
    consts = lambda name: request.constants(name, side)  # noqa: E731
    prior_pg = pg if setup.belief is None else setup.belief  # what the priors see: the belief (the oracle: the truth)
    seen = pg if request.predictions == "oracle" else prior_pg
    pred = predict_for(request, seen, clock, consts) if request.needs_priors else \
        Predicted(methods=tuple(get_method(m) for m in request.methods))
    ms = list(pred.methods)
    warn_fallbacks(pred.fallbacks, stacklevel=_caller + 1)
    with clock.stage("priors"):
        priors, thresholds = method_priors(ms, prior_pg, pred.region, pred.guideline, consts, pred.distance, pred.threshold)
    if "qi_distance" in pred.record:
        pred.record["qi_distance"] = qi_distance(ms, consts, thresholds, pred.record["qi_distance"])
    with clock.stage("startup"):
        compiled.warm_up()  # numba's kernels load from its disk cache (compile on the first run); C ones: nothing
    n_workers = check_workers(workers) if setup.belief is None else 1  # workers would rebuild priors on the truth
    with clock.stage("learn"):
        sensed = None if request.sensing is None else learn_sensed(  # revealed as it moves
            pg, prior_pg, request.belief.unknown, ms, list(request.seeds), consts, pred.region, pred.guideline,
            pred.distance, request.sensing, pred.record, pred.repredict)
        results = sensed if sensed is not None else learn(pg, ms, request.seeds, consts, priors, pred.region, pred.guideline, n_workers, keep_records,
                        progress, pred.distance, pred.threshold)
    with clock.stage("route"):
        runs = planned_runs(results, setup.check_map, pg, request.grid_map, request.settings.smoothing,
                            request.start_yaw, request.goal_yaw, pred.fallbacks)
    return PlanReport(
        grid_map=request.grid_map, start=request.start, goal=request.goal, grid=pg, methods=tuple(m.name for m in ms),
        seeds=request.seeds, results=tuple(runs), region=pred.region_map, guideline=pred.guideline_map,
        thresholds=thresholds, timings=dict(clock.wall), cpu_times=dict(clock.cpu), weights=pred.weights,
        info={**request.info, **pred.record, "kernels": compiled.backend(),
              **({"belief": belief_record(request.belief, request.unknown_rule, request.grid_map, pg, setup.belief)}
                 if request.belief is not None else {})}, config=consts(ms[0].name)[0],
        prior_config=consts(ms[0].name)[1],
        setup=setup, settings=request.settings, request=request,
    )


#: The keywords of :func:`solve` that go to :func:`build_request` (the request), the rest are how it runs.
REQUEST_KEYWORDS = ("start", "goal", "start_world", "goal_world", "scen", "scen_index", "methods", "seeds", "weights",
                    "predictions", "preset", "ql", "priors", "config", "prior_config", "settings", "sample", "invert",
                    "threshold", "crop", "hide", "unknown", "sense", "sense_every", "grid", "size", "robot_radius",
                    "smooth", "fallback", "tolerance", "max_map_pixels", "max_size", "threads", "backend",
                    "learned_distance", "symmetries", "predict_budget")
#: The request keywords whose "not given" value is not ``None`` (every other one is not given when ``None``).
_NOT_GIVEN: dict[str, Any] = {"invert": False, "threshold": 128, "crop": False, "fallback": "auto",
                              "predict_budget": DEFAULT_PREDICT_BUDGET}


def _given(values: dict[str, Any]) -> dict[str, Any]:
    """The request keywords of ``values`` that were given: not ``None`` (not at :data:`_NOT_GIVEN`'s value for
    those listed there, where ``None`` is a value: no fallback, no time limit)."""
    out = {}
    for k in REQUEST_KEYWORDS:
        v = values.get(k)
        if k in _NOT_GIVEN:
            d = _NOT_GIVEN[k]
            if v is d or (type(v) is type(d) and v == d):
                continue
        elif v is None:
            continue
        out[k] = v
    return out


@_named_arguments
def solve(map_or_request: Any, start: Sequence[int] | None = None, goal: Sequence[int] | None = None,
          methods: Sequence[str] | str = ("NDR-QL",), seeds: Sequence[int] | int = (0,), *,
          start_world: Sequence[float] | None = None, goal_world: Sequence[float] | None = None,
          scen: str | None = None, scen_index: int | None = None, weights: str | None = None, predictions: Any = None,
          preset: Any = None, ql: dict[str, Any] | None = None, priors: dict[str, Any] | None = None,
          config: Any = None, prior_config: Any = None, settings: PlanSettings | None = None,
          sample: dict[str, Any] | None = None, invert: bool = False, threshold: float = 128, crop: bool = False,
          hide: Any = None, unknown: str | None = None, sense: float | None = None, sense_every: int | None = None,
          grid: str | None = None, size: int | str | None = None, robot_radius: float | None = None,
          smooth: bool | None = None, fallback: str | None = "auto", tolerance: float | None = None,
          max_map_pixels: int | None = None, max_size: int | None = None, threads: int | None = None,
          backend: str | None = None, learned_distance: bool | None = None, symmetries: int | None = None,
          predict_budget: float | None = DEFAULT_PREDICT_BUDGET,
          workers: int | None = None, keep_records: bool = False, progress: bool = False) -> PlanReport:
    """Plan on one map with every method and every seed of a request; returns a :class:`PlanReport`.

    ``map_or_request``: a :class:`~ndrql.pipeline.request.PlanRequest` (from
    :func:`~ndrql.pipeline.request.build_request`; then no other request keyword), or a map (file,
    :class:`GridMap` or 2-D array, non-zero = obstacle) with the keywords of
    :func:`~ndrql.pipeline.request.build_request` (:data:`REQUEST_KEYWORDS`: the points in pixels or metres or a
    MovingAI scenario, the methods and seeds, where the priors come from, the constants) and of
    :class:`PlanSettings` (``grid``, ``size``, ``robot_radius``, ``fallback``, ``predict_budget``, ...). The
    defaults are ``ndrql plan``'s: on a map file the safe grid with ``size auto``; NDR-QL's priors from the exact
    source on a map the planner fully knows, from the network (the general weights) on a belief map (``hide=``) or
    with ``predictions="model"``; IQL-BFS when every source is rejected (then the run says so:
    ``requested_method``, ``fallback_reason``, and a :class:`~ndrql.errors.FallbackWarning`).

    ``workers``: processes for many runs (default: all cores; results do not depend on it);
    ``keep_records``: per-episode records in the results; ``progress``: a bar on a terminal.
    """
    fields = _given(dict(locals()))
    fields.pop("methods", None) if methods == ("NDR-QL",) else None
    fields.pop("seeds", None) if seeds == (0,) else None
    request = _request(map_or_request, (), SOLVE_POSITIONAL, fields)
    return run_request(request, workers=workers, keep_records=keep_records, progress=progress, _caller=2)


@_named_arguments
def plan(map_or_request: Any, start: Sequence[int] | None = None, goal: Sequence[int] | None = None,
         method: str = "NDR-QL", seed: int = 0, *, start_world: Sequence[float] | None = None,
         goal_world: Sequence[float] | None = None, scen: str | None = None, scen_index: int | None = None,
         weights: str | None = None, predictions: Any = None, preset: Any = None, ql: dict[str, Any] | None = None,
         priors: dict[str, Any] | None = None, config: Any = None, prior_config: Any = None,
         settings: PlanSettings | None = None, sample: dict[str, Any] | None = None, invert: bool = False,
         threshold: float = 128, crop: bool = False, hide: Any = None, unknown: str | None = None,
         sense: float | None = None, sense_every: int | None = None, grid: str | None = None,
         size: int | str | None = None, robot_radius: float | None = None, smooth: bool | None = None,
         fallback: str | None = "auto", tolerance: float | None = None, max_map_pixels: int | None = None,
         max_size: int | None = None, threads: int | None = None, backend: str | None = None,
         learned_distance: bool | None = None, symmetries: int | None = None,
         predict_budget: float | None = DEFAULT_PREDICT_BUDGET, workers: int | None = None) -> PlannedRun:
    """Plan a path with one method and one seed; returns the run (a :class:`PlanResult` with its route).

    ``ndrql.plan("map.png", start=(25, 179), goal=(167, 5))`` runs NDR-QL with seed 0; ``method=`` and
    ``seed=`` choose others, and the keywords are those of :func:`solve`. ``result.path`` is in
    planning-grid cells; ``result.route`` is the path on the map (checked for collisions, shortcut, with
    world poses on ROS maps) and ``result.success`` says whether it holds. When every prior source is rejected,
    IQL-BFS runs instead: ``result.method`` is then ``"IQL-BFS"``, ``result.requested_method`` ``"NDR-QL"``,
    ``result.fallback_reason`` says why, and a :class:`~ndrql.errors.FallbackWarning` is issued.
    """
    fields = _given(dict(locals()))
    if not isinstance(map_or_request, PlanRequest):
        fields["methods"], fields["seeds"] = (method,), (seed,)
    elif method != "NDR-QL" or seed != 0:
        raise NdrqlError("a PlanRequest is the whole plan: change it with build_request, not with more arguments")
    request = _request(map_or_request, (), SOLVE_POSITIONAL, fields)
    if len(request.methods) * len(request.seeds) != 1:
        raise NdrqlError("plan runs one method with one seed; use solve for this request")
    return run_request(request, workers=workers, _caller=2).results[0]


@_named_arguments
def astar(map_or_request: Any, start: Sequence[int] | None = None, goal: Sequence[int] | None = None, *,
          octile: bool = False, start_world: Sequence[float] | None = None, goal_world: Sequence[float] | None = None,
          scen: str | None = None, scen_index: int | None = None, grid: str | None = None, size: int | str | None = None,
          robot_radius: float | None = None, smooth: bool | None = None, max_size: int | None = None,
          max_map_pixels: int | None = None, invert: bool = False, threshold: float = 128,
          crop: bool = False) -> AStarRun:
    """The shortest path with A* on the request ``plan`` builds, no learning; returns an :class:`AStarRun`
    (``method``, ``path``, ``path_length``, ``route``, ``success``, ``path_pixels``, ``poses`` as a :class:`PlannedRun`).

    ``ndrql.astar("map.png", start=(25, 179), goal=(167, 5))``: 4-connected unit moves on plan's planning grid
    (the safe grid with ``size auto`` on a map file), the path as a route on the full map (checked, shortcut
    unless ``smooth=False``, world poses on ROS maps). ``octile=True``: 8-connected octile moves without corner
    cutting on the full-resolution map inflated by ``robot_radius`` (``grid``, ``size``, ``smooth`` do not
    apply). The other keywords are :func:`build_request`'s; ``map_or_request`` may also be a :class:`PlanRequest`.
    ``ndrql astar`` runs this search.
    """
    if octile and (grid is not None or size is not None or smooth):
        raise NdrqlError("octile A* searches the full map: drop grid, size and smooth")
    if isinstance(map_or_request, PlanRequest):
        given = [n for n, v in (("start", start), ("goal", goal), ("start_world", start_world), ("goal_world", goal_world),
                                ("scen", scen), ("scen_index", scen_index), ("grid", grid), ("size", size),
                                ("robot_radius", robot_radius), ("smooth", smooth), ("max_size", max_size),
                                ("max_map_pixels", max_map_pixels)) if v is not None]
        if given or invert or crop or threshold != 128:
            raise NdrqlError("a PlanRequest is the whole plan: change it with build_request, not with more arguments")
        return search(map_or_request, octile=octile)
    request = build_request(map_or_request, start, goal, start_world=start_world, goal_world=goal_world, scen=scen,
                            scen_index=scen_index, methods=("QL",), grid=grid, size=size, robot_radius=robot_radius,
                            smooth=False if octile else smooth, max_size=max_size, max_map_pixels=max_map_pixels,
                            invert=invert, threshold=threshold, crop=crop)
    return search(request, octile=octile)


def cell_path_to_pixels(report: PlanReport, path: Sequence[Sequence[int]]) -> list[tuple[float, float]]:
    """A planning-grid path as ``(row, col)`` map-pixel coordinates of the cell centres (pixel ``(r, c)``'s
    centre is ``(r, c)``; fractional values fall between pixels)."""
    return [report.grid.centre(c) for c in path]


__all__ = ["AStarRun", "FallbackWarning", "GivenPredictions", "NdrqlWarning", "PlanReport", "PlanRequest", "PlanSettings",
           "PlannedRun", "STAGES", "WORK_STAGES", "astar", "build_request", "plan", "run_request", "solve", "read_map",
           "scenario_points", "check_points", "cell_path_to_pixels", "load_predictions"]
