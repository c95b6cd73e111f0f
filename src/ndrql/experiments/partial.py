"""``ndrql reproduce partial``: NDR-QL on maps the planner does not fully know (issue 54), against IQL-BFS on the belief.

For every map of an evaluation set (default the development set ``partial-dev``), planning grid ``n``, belief
setting (:class:`BeliefSetting`: :mod:`ndrql.synth.masks`' blobs hiding a share of the free space, what a robot
sensed along routes, an outdated map; drawn from ``default_rng([MASK_SEED, map index, kind, percent])``) and
sensing off or on, the agent learns on the **true** map's safe grid of ``n`` cells (or the first larger size of
the ladder on which the truth connects start and goal, as ``reproduce transfer``), with the same seeds and the
preset ``plan`` takes on a belief map (``belief``: general's constants, NDR-QL's and IQL-BFS's searched on belief maps;
the rows of the true map, a known map, take ``general``'s). Rows, each a ratio to **IQL-BFS (belief)**:

- ``IQL``: straight-line priors (no map);
- ``IQL-BFS (belief)``: what ``ndrql plan MAP --hide MASK --methods IQL-BFS --size n`` runs (Eq. 5 on the exact BFS
  distance of the belief, unknown counted free): the reference;
- ``NDR-QL``: what ``ndrql plan MAP --hide MASK --size n`` runs: the same request and pipeline, the model source,
  the judge and the IQL-BFS fallback included (the record says which source served, or why it fell back);
- ``IQL-NDR``: what ``ndrql plan MAP --hide MASK --size n --methods IQL-NDR`` runs: IQL's priors with Eq. 5 on the
  served source's goal distance (the model's, floored at the belief's BFS distance), the same pipeline and fallback;
- ``NDR-QL (model)``: the model's own priors on the belief's grid (Eq. 6's mask off, as ``plan`` on a belief map),
  no judge (when the judge accepted them they are the ``NDR-QL`` row's; with sensing on the row is not run);
- ``NDR-QL (oracle)``: the oracle's priors of the true grid (:func:`~ndrql.experiments.ceiling.oracle_priors`): the
  ceiling, a prediction that knows what is hidden.

Sensing on is ``--sense R`` with R = :data:`SENSE_SHARE` of the grid's side, on both belief rows. The rows that do
not depend on the belief (``IQL``, the oracle) run once per map and grid. Records are JSON lines, one per task,
resumable (:class:`~ndrql.io.jsonl.BatchLog`); :mod:`ndrql.experiments.partial_report` writes the report.
The studies in ``studies/partial`` take their cases and rows from here.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import time
import warnings
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Any, Callable, Iterator

import numpy as np

from ndrql.errors import FallbackWarning, NdrqlError
from ndrql.experiments.ceiling import GridCase, grid_case, larger_sizes, oracle_priors
from ndrql.experiments.eval_sets import eval_set, eval_spec
from ndrql.maps.belief import Belief, unknown_cells
from ndrql.maps.grid import GridMap, SnapWarning
from ndrql.maps.sizing import safe_grid
from ndrql.model.predict import load_predictor
from ndrql.model.weights import weights_label
from ndrql.pipeline.problem import map_grid
from ndrql.pipeline.request import build_request, request_settings
from ndrql.pipeline.sources import ModelSource, SourceInput, belief_floor
from ndrql.planning.methods import Priors, build_priors
from ndrql.planning.preset import BELIEF_PRESET, load_preset
from ndrql.planning.priors import ThresholdWarning
from ndrql.planning.runner import astar_length, run_plan
from ndrql.synth.masks import KINDS, draw_belief

#: The seed of every mask: map ``i``'s belief draws from ``default_rng([MASK_SEED, i, kind, percent])``.
MASK_SEED = 54
#: Sensing radius of ``--sense on``: this share of the planning grid's side (4 cells at 50, 8 at 100; the studies').
SENSE_SHARE = 0.08
#: The belief settings by default: blobs hiding 10/30/50% of the free space, sensed routes, an outdated map.
DEFAULT_BELIEFS = "blobs:0.1,blobs:0.3,blobs:0.5,sensed,outdated"
#: The reference row every other row is divided by.
REF = "IQL-BFS (belief)"
#: The report's rows, in order.
ROWS = ("IQL", REF, "NDR-QL", "IQL-NDR", "NDR-QL (model)", "NDR-QL (oracle)")
#: The methods whose request names the task's weights (the rows that ask the model through ``plan``).
MODEL_METHODS = ("NDR-QL", "IQL-NDR")
#: The rows that do not depend on the belief (one task per map and grid).
TRUTH_ROWS = ("IQL", "NDR-QL (oracle)")
#: The records' format tag (:class:`~ndrql.io.jsonl.BatchLog`).
FORMAT = "ndrql-partial"


@dataclass(frozen=True)
class BeliefSetting:
    """One kind of belief: ``blobs`` with the share of the free space it hides, ``sensed`` or ``outdated``."""

    kind: str
    """A kind of :data:`ndrql.synth.masks.KINDS`."""
    fraction: float = 0.3
    """Share of the free space hidden (blobs; the other kinds draw their seed with it, as the studies did)."""

    @property
    def label(self) -> str:
        return f"{self.kind}:{self.fraction:g}" if self.kind == "blobs" else self.kind

    def rng(self, index: int) -> np.random.Generator:
        """The generator of map ``index``'s mask."""
        return np.random.default_rng([MASK_SEED, index, KINDS.index(self.kind), int(round(100 * self.fraction))])

    def draw(self, obstacles: np.ndarray, start, goal, index: int) -> Belief:
        """Map ``index``'s belief of this setting."""
        return draw_belief(self.kind, obstacles, start, goal, self.rng(index), fraction=self.fraction)


def parse_beliefs(text: str) -> tuple[BeliefSetting, ...]:
    """``blobs:0.1,blobs:0.3,sensed,outdated`` as settings; one clear error for anything else."""
    out = []
    for item in (t.strip() for t in str(text).split(",")):
        if not item:
            continue
        kind, _, frac = item.partition(":")
        if kind not in KINDS:
            raise NdrqlError(f"--beliefs: unknown kind {kind[:40]!r}; valid: {', '.join(KINDS)} (blobs:FRACTION)")
        if kind != "blobs":
            if frac:
                raise NdrqlError(f"--beliefs: {kind} takes no fraction (only blobs:FRACTION does)")
            out.append(BeliefSetting(kind))
            continue
        try:
            f = float(frac or 0.3)
        except ValueError:
            raise NdrqlError(f"--beliefs: blobs:FRACTION needs a number in (0, 0.9], got {frac[:40]!r}") from None
        if not 0 < f <= 0.9:
            raise NdrqlError(f"--beliefs: blobs:FRACTION needs a number in (0, 0.9], got {frac[:40]!r}")
        out.append(BeliefSetting("blobs", f))
    if not out:
        raise NdrqlError("--beliefs is empty; give e.g. blobs:0.3,sensed")
    return tuple(dict.fromkeys(out))


def parse_sense(text: str) -> tuple[bool, ...]:
    """``off,on`` as ``(False, True)``."""
    items = [t.strip() for t in str(text).split(",") if t.strip()]
    bad = [t for t in items if t not in ("off", "on")]
    if bad or not items:
        raise NdrqlError(f"--sense takes off, on or off,on, got {str(text)[:40]!r}")
    return tuple(dict.fromkeys(t == "on" for t in items))


# --- the cases --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PartialCase:
    """One map of a set at one grid with one belief: the truth's case (``None``: no ladder size connects), the
    belief's grid on the truth's cells, and the belief itself (map pixels)."""

    index: int
    family: str
    obstacles: np.ndarray
    start: tuple[int, int]
    goal: tuple[int, int]
    belief: Belief
    case: GridCase | None
    bcase: GridCase | None

    @property
    def unknown_share(self) -> float:
        return float(self.belief.unknown_share(self.obstacles))

    @property
    def unknown(self) -> np.ndarray | None:
        """The belief grid's cells holding an unknown pixel (what ``plan --hide`` gives a model with the channel)."""
        return None if self.case is None else case_unknown(self.case, self.belief.unknown)


def belief_case(case: GridCase, belief_obstacles: np.ndarray) -> GridCase:
    """The belief's safe grid at the case's size, start and goal on the truth's cells (kept free)."""
    blocked = map_grid(GridMap(belief_obstacles), request_settings(grid="safe", size=case.n))[0]
    blocked[case.start_cell] = blocked[case.goal_cell] = False
    return GridCase(belief_obstacles, case.start, case.goal, name=case.name, group=case.group, n=case.n,
                    blocked=blocked, start_cell=case.start_cell, goal_cell=case.goal_cell)


def case_unknown(case: GridCase, unknown_px: np.ndarray) -> np.ndarray:
    """The case's planning cells holding an unknown pixel (square cells of max(H, W) / n px)."""
    side = max(case.obstacles.shape) / case.n
    return unknown_cells(unknown_px, SimpleNamespace(shape=case.blocked.shape, cell_size=(side, side)))


def one_case(gs: Any, index: int, grid: int, setting: BeliefSetting) -> PartialCase:
    """Map ``index`` of the generated set ``gs`` at ``grid`` with ``setting``'s belief."""
    raw, fam = gs.raw(index), str(gs.families[index])
    belief = setting.draw(raw.obstacles, raw.start, raw.goal, index)
    case = grid_case(f"{fam}-{index}-g{grid}", fam, raw.obstacles, raw.start, raw.goal, grid, larger_sizes(grid))
    bcase = None if case is None else belief_case(case, belief.planner_obstacles("free"))
    return PartialCase(index, fam, raw.obstacles, tuple(raw.start), tuple(raw.goal), belief, case, bcase)


def partial_cases(gs: Any, grid: int, setting: BeliefSetting, limit: int | None = None) -> Iterator[PartialCase]:
    """Every map of ``gs`` (the first ``limit``) at ``grid`` with ``setting``'s belief."""
    for i in range(len(gs) if limit is None else min(limit, len(gs))):
        yield one_case(gs, i, grid, setting)


# --- the rows ---------------------------------------------------------------------------------------------


def steps_of(r: Any) -> int:
    """Convergence steps, or every step of a run that did not converge."""
    return int(r.convergence_steps if r.converged else r.total_steps)


def row_record(runs: list, seconds: float = 0.0) -> dict[str, Any]:
    """Steps, convergence and path / A* of each seed's run, and the seconds of the priors."""
    return {"steps": [steps_of(r) for r in runs], "converged": [bool(r.converged) for r in runs],
            "ratio": [None if r.length_ratio is None else float(r.length_ratio) for r in runs],
            "seconds": round(float(seconds), 4)}


def run_rows(case: GridCase, jobs: dict[str, tuple[str, Priors, float]], preset: Any, seeds: list[int]) -> dict:
    """Each ``row: (method, priors, seconds of the priors)`` with every seed on the true grid of ``case``."""
    n = max(case.blocked.shape)
    args = (case.start_cell, case.goal_cell)
    opt = astar_length(case.blocked, *args)
    rows = {}
    for row, (method, pri, seconds) in jobs.items():
        ql = preset.configs(method, grid=n)[0]
        rows[row] = row_record([run_plan(case.blocked, *args, method, s, ql, priors=pri, astar=opt) for s in seeds],
                               seconds)
    return {"astar": opt, "rows": rows}


def plain_priors(method: str, case: GridCase, preset: Any) -> Priors:
    """``method``'s priors without a prediction (IQL, IQL-BFS) on ``case``'s grid."""
    n = max(case.blocked.shape)
    return build_priors(method, case.blocked, case.start_cell, case.goal_cell, cfg=preset.configs(method, grid=n)[1])


def ndr_priors(case: GridCase, region: np.ndarray, guide: np.ndarray, dist: np.ndarray | None, preset: Any,
               mask: bool = True) -> Priors:
    """NDR-QL's priors (Eqs. 2-7) from region, guideline and goal distance on ``case``'s grid; ``mask=False``:
    Eq. 6 without its mask term, as ``plan`` builds them on a belief map
    (:data:`ndrql.pipeline.prior_stage.BELIEF_MASK`)."""
    cfg = preset.configs("NDR-QL", grid=max(case.blocked.shape))[1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ThresholdWarning)
        return build_priors("NDR-QL", case.blocked, case.start_cell, case.goal_cell, region, guide, cfg, dist,
                            ... if mask else None)


def oracle_job(case: GridCase, preset: Any) -> tuple[str, Priors, float]:
    """The ceiling: NDR-QL with the oracle's priors of ``case``'s (true) grid."""
    t0 = time.perf_counter()
    pri = ndr_priors(case, *oracle_priors(case, distance=True), preset)
    return "NDR-QL", pri, time.perf_counter() - t0


def model_job(predictor: Any, pc: PartialCase, preset: Any) -> tuple[tuple[str, Priors, float], Any]:
    """NDR-QL with the model's own priors on the belief's grid (no judge, no fallback) and the prediction: what
    :class:`~ndrql.pipeline.sources.ModelSource` predicts, the unknown cells given to a model with the channel. Where
    something is hidden, as ``plan --hide`` builds them (Eq. 6's mask off, the goal distance floored at the belief's
    BFS distance, :func:`~ndrql.pipeline.sources.belief_floor`; also for a model without the channel, which ``plan``
    would not ask); where nothing is, as on a known map (the mask on, no floor)."""
    bgrid = dataclasses.replace(safe_grid(pc.belief.planner_obstacles("free"), pc.case.n, pc.start, pc.goal),
                                blocked=pc.bcase.blocked, start=pc.case.start_cell, goal=pc.case.goal_cell)
    partial = bool(np.any(pc.belief.unknown))
    t0 = time.perf_counter()
    out = ModelSource(predictor).give(SourceInput(bgrid, GridMap(pc.belief.planner_obstacles("free")), pc.start, pc.goal,
                                                  unknown=pc.unknown))
    distance = belief_floor(out.distance, bgrid.blocked, bgrid.goal) if partial else out.distance
    pri = ndr_priors(pc.bcase, out.region, out.guideline, distance, preset, mask=not partial)
    return ("NDR-QL", pri, time.perf_counter() - t0), out


# --- the tasks --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Task:
    """One record: the rows of one map at one grid (``belief`` ``None``: the truth's rows, else that setting)."""

    set_name: str
    release: bool
    index: int
    grid: int
    seeds: tuple[int, ...]
    preset: str
    weights: str | None = None
    belief: str | None = None
    sense: bool = False
    runner: Callable[[Any], Any] | None = field(default=None, compare=False)
    """What runs a plan's request (the CLI passes :func:`ndrql.api.run_request`: the layer above this one)."""

    @property
    def id(self) -> int:
        """A stable number of the task (the record's ``id``)."""
        text = f"{self.index}|{self.grid}|{self.belief}|{self.sense}"
        return int(hashlib.sha256(text.encode()).hexdigest()[:12], 16)


@functools.lru_cache(maxsize=2)
def _generated(set_name: str, release: bool) -> Any:
    return eval_set(eval_spec(set_name, release=release), False, release=release)


def run_task(task: Task) -> dict[str, Any]:
    """The record of ``task`` (runs in a worker process)."""
    gs = _generated(task.set_name, task.release)
    setting = parse_beliefs(task.belief or "blobs:0.3")[0]
    pc = one_case(gs, task.index, task.grid, setting)
    rec: dict[str, Any] = {"id": task.id, "index": task.index, "family": pc.family, "grid": task.grid,
                           "belief": task.belief, "sense": task.sense}
    if pc.case is None:
        return {**rec, "skipped": "start and goal do not connect on the ladder"}
    known = task.belief is None and task.preset == BELIEF_PRESET  # the truth's rows: a known map's constants
    preset = load_preset("general" if known else task.preset)
    rec["n"] = pc.case.n
    t0 = time.perf_counter()
    if task.belief is None:
        jobs = {"IQL": ("IQL", plain_priors("IQL", pc.case, preset), 0.0), "NDR-QL (oracle)": oracle_job(pc.case, preset)}
        rec.update(run_rows(pc.case, jobs, preset, list(task.seeds)))
    else:
        rec["unknown_share"] = round(pc.unknown_share, 4)
        rec.update(belief_rows(pc, task, preset))
    rec["seconds"] = round(time.perf_counter() - t0, 3)
    return rec


def plan_request(pc: PartialCase, task: Task, method: str) -> Any:
    """The request ``ndrql plan MAP --hide MASK --size n [--sense R] --methods METHOD`` builds for ``pc``."""
    radius = round(SENSE_SHARE * pc.case.n, 3) if task.sense else None
    return build_request(pc.obstacles, pc.start, pc.goal, methods=[method], seeds=list(task.seeds), hide=pc.belief,
                         size=pc.case.n, preset=task.preset, sense=radius,
                         weights=task.weights if method in MODEL_METHODS else None)


def _pipeline_row(report: Any) -> dict[str, Any]:
    seconds = report.timings.get("predict", 0.0) + report.timings.get("priors", 0.0)
    return row_record(list(report.results), seconds)


def belief_rows(pc: PartialCase, task: Task, preset: Any) -> dict[str, Any]:
    """The belief's rows of one case (module docstring); a request ``plan`` refuses is recorded as refused."""
    run_request = task.runner
    rows: dict[str, Any] = {}
    try:
        with warnings.catch_warnings():  # what they say is in the record (sources, fallback)
            for category in (FallbackWarning, SnapWarning, ThresholdWarning):
                warnings.simplefilter("ignore", category)
            rows[REF] = _pipeline_row(run_request(plan_request(pc, task, "IQL-BFS")))
            request = plan_request(pc, task, "NDR-QL")
            report = run_request(request)
    except NdrqlError as exc:
        return {"refused": str(exc)[:300], "rows": rows}
    rows["NDR-QL"] = _pipeline_row(report)
    trials = report.info.get("sources", [])
    served = next((t["source"] for t in trials if t.get("accepted")), None)
    fb = report.info.get("fallback")
    ndr = {"served": served, "weights": request.weights_file, "weights_label": _label(request.weights_file),
           "fallback": None if fb is None else {"ran": fb["ran"], "reasons": fb["reasons"]},
           "sources": trials, "sensing": "sensing" in report.info}
    if served == "model":
        rows["NDR-QL (model)"] = {**rows["NDR-QL"], "same_as": "NDR-QL"}
    elif not task.sense and request.weights_file is not None:
        s = request.settings
        job, _ = model_job(load_predictor(request.weights_file, s.threads, s.backend, s.symmetries), pc, preset)
        rows["NDR-QL (model)"] = run_rows(pc.case, {"NDR-QL (model)": job}, preset, list(task.seeds))["rows"]["NDR-QL (model)"]
    out = {"astar": astar_length(pc.case.blocked, pc.case.start_cell, pc.case.goal_cell), "rows": rows, "ndr": ndr}
    iql_ndr = iql_ndr_row(pc, task)
    if "row" in iql_ndr:
        rows["IQL-NDR"] = iql_ndr.pop("row")
    return {**out, "iql_ndr": iql_ndr}


def iql_ndr_row(pc: PartialCase, task: Task) -> dict[str, Any]:
    """The ``IQL-NDR`` row through ``plan``'s request (``row``), which source served and the fallback; a request
    ``plan`` refuses (e.g. weights without a distance head) is recorded as ``refused``, the other rows kept."""
    try:
        with warnings.catch_warnings():
            for category in (FallbackWarning, SnapWarning, ThresholdWarning):
                warnings.simplefilter("ignore", category)
            report = task.runner(plan_request(pc, task, "IQL-NDR"))
    except NdrqlError as exc:
        return {"refused": str(exc)[:300]}
    served = next((t["source"] for t in report.info.get("sources", []) if t.get("accepted")), None)
    fb = report.info.get("fallback")
    return {"row": _pipeline_row(report), "served": served, "qi_distance": report.info.get("qi_distance"),
            "fallback": None if fb is None else fb["ran"]}


def _label(path: str | None) -> str | None:
    return None if path is None else weights_label(path)


__all__ = ["DEFAULT_BELIEFS", "FORMAT", "MASK_SEED", "REF", "ROWS", "SENSE_SHARE", "BeliefSetting", "PartialCase", "Task",
           "belief_case", "belief_rows", "case_unknown", "iql_ndr_row", "model_job", "ndr_priors", "one_case", "oracle_job",
           "parse_beliefs", "parse_sense", "partial_cases", "plain_priors", "plan_request", "row_record", "run_rows",
           "run_task", "steps_of"]
