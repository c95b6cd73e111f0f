"""What :func:`ndrql.api.solve` returns: :class:`PlanReport` (problem, predictions, runs, timings) and
:class:`PlannedRun` (a Q-learning run with its path on the map), with their JSON form."""

from __future__ import annotations

import dataclasses
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, Iterator, Sequence

import numpy as np

from ndrql.maps.grid import GridMap, PlanningGrid
from ndrql.pipeline.problem import GridSetup
from ndrql.pipeline.route import Route, make_route, octile_cost
from ndrql.pipeline.settings import PlanSettings
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.priors import schedule_text, threshold_schedule
from ndrql.planning.results import PlanResult, summarize

Point = tuple[int, int]

#: Stages timed by :func:`solve`, in order. ``startup`` is per-process (numba kernel load from its
#: disk cache); ``load`` is the model's, once per process (with the torch import on the torch backend
#: or when ONNX Runtime's export is not cached yet); ``grid`` is inflation, the size search and the
#: planning grid; ``route`` the paths' check and shortcut on the full map; the others the work for one map.
STAGES: tuple[str, ...] = ("startup", "map", "grid", "load", "predict", "priors", "learn", "route")
#: The stages that make up the work for one map after start-up (the 0.5 s budget of issue 6).
WORK_STAGES: tuple[str, ...] = ("load", "predict", "priors", "learn")


#: Seconds a stage runs before :class:`StageClock` shows it on a terminal.
SHOW_AFTER = 2.0


class StageClock:
    """Wall and CPU time per named stage of :data:`STAGES` (accumulating). With ``show`` (a text stream, a
    terminal), a stage that runs longer than :data:`SHOW_AFTER` seconds is shown on one line that counts the
    seconds until it ends, then erased."""

    def __init__(self, show: Any = None) -> None:
        self.wall: dict[str, float] = {s: 0.0 for s in STAGES}
        self.cpu: dict[str, float] = {s: 0.0 for s in STAGES}
        self._show = show

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        w, c = time.perf_counter(), time.process_time()
        done = threading.Event()
        ticker = None
        if self._show is not None:
            ticker = threading.Thread(target=self._tick, args=(name, w, done), daemon=True)
            ticker.start()
        try:
            yield
        finally:
            done.set()
            if ticker is not None:
                ticker.join()
            self.wall[name] += time.perf_counter() - w
            self.cpu[name] += time.process_time() - c

    def _tick(self, name: str, t0: float, done: threading.Event) -> None:
        """Show ``name`` and its seconds once a second after :data:`SHOW_AFTER`, erase the line when it ends."""
        if done.wait(SHOW_AFTER):
            return
        out = self._show
        while not done.wait(1.0 if out is not None else 0):
            out.write(f"\rndrql: {name} ... {time.perf_counter() - t0:.0f} s ")
            out.flush()
        out.write("\r" + " " * 40 + "\r")
        out.flush()


@dataclass(frozen=True)
class PlannedRun(PlanResult):
    """A :class:`PlanResult` with its path on the map: :attr:`route` (checked, shortcut, world poses)."""

    route: Route | None = field(default=None, compare=False, repr=False)
    """The learned path on the full map (``None`` when the run found no path)."""
    requested_method: str | None = None
    """The method asked for: :attr:`method` itself, or the NDR method the fallback replaced."""
    fallback_reason: str | None = None
    """Why :attr:`method` ran instead of :attr:`requested_method` (``None``: it was the one asked for)."""

    def to_dict(self, include_records: bool = False) -> dict[str, Any]:
        """The run's JSON form (the route is added by :meth:`PlanReport.to_dict`)."""
        out = super().to_dict(include_records=include_records)
        out.pop("route", None)
        out["requested_method"] = self.requested_method or self.method
        out["fallback_reason"] = self.fallback_reason
        return out

    @property
    def fell_back(self) -> bool:
        """Whether another method ran than the one asked for."""
        return self.fallback_reason is not None

    @property
    def success(self) -> bool:
        """Converged, and the final path crosses no obstacle of the (inflated) map."""
        return bool(self.converged and self.route is not None and not self.route.collides)

    @property
    def path_pixels(self) -> np.ndarray | None:
        """The final path in map pixels ``(M, 2)`` (``(row, col)``)."""
        return None if self.route is None else self.route.pixels

    @property
    def poses(self) -> np.ndarray | None:
        """The final path as map-frame poses ``(M, 3)``: x, y in metres, yaw in radians (ROS maps only)."""
        return None if self.route is None else self.route.poses

    @property
    def collisions(self) -> list[tuple[int, tuple[int, int]]]:
        """Segments of the final path that cross an obstacle: ``(segment, first blocked pixel)``."""
        return [] if self.route is None else list(self.route.final_collisions)


@dataclass(frozen=True)
class PlanReport:
    """Everything :func:`solve` computed: problem, predictions, runs, their paths on the map and timings."""

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
    results: tuple[PlannedRun, ...]
    """One result per (method, seed), methods outer, each with its route on the map."""
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
    setup: GridSetup | None = None
    """How the map became the planning grid (rule, size, robot radius) and the map paths were checked on."""
    settings: PlanSettings = PlanSettings()
    """The settings of this plan."""
    request: Any = field(default=None, repr=False, compare=False)
    """The :class:`~ndrql.pipeline.request.PlanRequest` this report answers."""

    @property
    def requested_methods(self) -> tuple[str, ...]:
        """The methods asked for (:attr:`methods` are those that ran)."""
        return tuple(self.request.methods) if self.request is not None else self.methods

    @property
    def astar_length(self) -> int:
        """Optimal 4-connected path length on the planning grid."""
        return self.results[0].astar_length

    @property
    def work_time(self) -> float:
        """Wall seconds of load + predict + priors + learn."""
        return sum(self.timings.get(s, 0.0) for s in WORK_STAGES)

    def runs(self, method: str) -> list[PlannedRun]:
        """The results of one method, in seed order."""
        return [r for r in self.results if r.method == method]

    def threshold_reason(self, method: str) -> str | None:
        """Why ``method`` ran without an NDR-QI threshold (``None`` when it had one, or runs no NDR-QI): its
        constants' Eq. 7 schedule joins start and goal nowhere. When the prediction was still judged informative
        (the judge searches the paper's schedule, down to 0), it says that the method's schedule stops above the
        threshold that joins them, so the two verdicts do not read as a contradiction."""
        if method not in self.thresholds or self.thresholds[method] is not None:
            return None
        if self.info.get("qi_mask"):
            return str(self.info["qi_mask"])
        if self.request is None:
            return "mask 0 everywhere"
        cfg = self.request.constants(method, max(self.grid.blocked.shape))[1]
        q = self.info.get("prediction_quality") or {}
        joins, lowest = q.get("threshold"), threshold_schedule(cfg)[-1]
        if q.get("informative") and joins is not None and joins < lowest:
            return (f"mask 0 everywhere: its schedule {schedule_text(cfg)} stops above {joins:.2f}, the highest "
                    f"threshold that joins start and goal")
        return f"mask 0 everywhere: no threshold in {schedule_text(cfg)} joins start and goal"

    def _run_dict(self, r: PlannedRun, include_records: bool) -> dict[str, Any]:
        out = r.to_dict(include_records=include_records)
        out["success"] = r.success
        if r.path:
            out["path_pixels"] = [[round(a, 3), round(b, 3)] for a, b in (self.grid.centre(c) for c in r.path)]
        if r.route is not None:
            route = r.route.to_dict(self.grid_map)
            out["collisions"] = route["final_collisions"]
            if "poses" in route:
                out["path_world"] = route["poses"]
            out["route"] = route
            out["octile_cost"] = round(octile_cost(r.route.pixels), 4)
            auto = self.setup.auto if self.setup is not None else None
            if auto is not None and auto.full_length > 0:  # the scenario batch's ratio: octile over octile
                out["octile_ratio"] = round(out["octile_cost"] / auto.full_length, 5)
        else:
            out["collisions"] = []
        return out

    def to_dict(self, include_records: bool = False) -> dict[str, Any]:
        """The JSON form written by ``ndrql plan --json`` (plain types only)."""
        gm = self.grid_map
        map_info: dict[str, Any] = {"source": gm.source, "height": gm.height, "width": gm.width,
                                    "obstacle_ratio": round(gm.obstacle_ratio, 6)}
        if gm.resolution is not None:
            map_info["resolution"] = gm.resolution
        if gm.origin is not None:
            map_info["origin"] = list(gm.origin)
        pg = self.grid
        first = self.results[0]
        out = {
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
            "requested_methods": list(self.requested_methods),
            "seeds": list(self.seeds),
            "config": dataclasses.asdict(self.config),
            "prior_config": dataclasses.asdict(self.prior_config),
            "weights": self.weights,
            "prior_from": self.info.get("prior_from"),
            "ndr_qi_threshold": dict(self.thresholds),
            "ndr_qi_threshold_reason": {m: self.threshold_reason(m) for m in self.thresholds
                                        if self.thresholds[m] is None},
            "timings": {"wall": dict(self.timings), "cpu": dict(self.cpu_times), "work_wall": self.work_time},
            "summary": {
                m: {
                    "runs": len(self.runs(m)),
                    "not_converged": sum(not r.converged for r in self.runs(m)),
                    "success": sum(r.success for r in self.runs(m)),
                    "collide": sum(bool(r.collisions) for r in self.runs(m)),
                    "convergence_steps": summarize([r.convergence_steps for r in self.runs(m) if r.converged]),
                    "convergence_episode": summarize([r.convergence_episode for r in self.runs(m) if r.converged]),
                    "length_ratio": summarize([r.length_ratio for r in self.runs(m) if r.converged]),
                }
                for m in self.methods
            },
            "runs": [self._run_dict(r, include_records) for r in self.results],
            "first": {"method": first.method, "seed": first.seed},
        }
        if self.setup is not None:
            out["planning_grid"] = self.setup.to_dict(pg, gm.resolution)
        if self.request is not None:  # what was asked for, every default decided (the builder's record)
            out["request"] = self.request.to_dict()
        return out


def planned_runs(results: Sequence[PlanResult], check_map: np.ndarray, grid: PlanningGrid, grid_map: GridMap,
                 smooth: bool, start_yaw: float | None = None, goal_yaw: float | None = None,
                 fallbacks: Sequence[Any] = ()) -> list[PlannedRun]:
    """Each run with its learned path on the full map (:func:`~ndrql.pipeline.route.make_route`); runs
    whose seeds agree on the path share one route (it is checked once). ``fallbacks``: the
    :class:`~ndrql.pipeline.predictions.Fallback` records, which name the method each replaced run was asked for."""
    swapped = {}
    for f in fallbacks:
        swapped.setdefault(f.ran, f)
    routes: dict[tuple[tuple[int, int], ...], Route] = {}
    runs = []
    for r in results:
        route = None
        if r.path:
            key = tuple((int(a), int(b)) for a, b in r.path)
            if key not in routes:
                routes[key] = make_route(check_map, grid, r.path, grid_map, smooth=smooth, start_yaw=start_yaw,
                                         goal_yaw=goal_yaw)
            route = routes[key]
        fields = {f.name: getattr(r, f.name) for f in dataclasses.fields(PlanResult)}
        fb = swapped.get(r.method)
        runs.append(PlannedRun(**fields, route=route, requested_method=fb.requested if fb else r.method,
                               fallback_reason=fb.reason if fb else None))
    return runs
