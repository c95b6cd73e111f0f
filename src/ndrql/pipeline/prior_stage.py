"""The prediction stage of a plan: the request's prior sources, one judge, a time budget, the exact prior as the floor.

:func:`predict_for` builds the sources a request asks for (:mod:`ndrql.pipeline.sources`: the network by default,
``"oracle"``/``"exact"`` or given arrays with ``plan --prior-from``), asks them in order under the request's time
budget (``PlanSettings.predict_budget``, the prediction's, counted once the model is loaded) and keeps the first the judge accepts
(:func:`ndrql.pipeline.judge.consult`: one Eq. 7 search per prediction, whose threshold the priors then use). When
none is accepted, each NDR method is replaced by the request's fallback (IQL-BFS on a user's map, the exact
distance), said in the run (``requested_method``, ``fallback_reason``) and with a
:class:`~ndrql.errors.FallbackWarning`. The typed trace of what was tried goes into the JSON (``sources``) and the
summary, rendered once (:func:`ndrql.cli.plan_report.sources_text`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ndrql.errors import NdrqlError
from ndrql.maps.belief import unknown_cells
from ndrql.maps.grid import PlanningGrid
from ndrql.model.predict import load_predictor
from ndrql.pipeline.fallback import Fallback, fall_back, min_threshold
from ndrql.pipeline.judge import Trial, consult
from ndrql.pipeline.report import StageClock
from ndrql.pipeline.sources import (ExactSource, GivenSource, HeadSource, ModelSource, OracleSource, Repredict,
                                   SourceInput, belief_predictor)
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import Method, get_method
from ndrql.synth.oracle import ORACLE_NAME

#: What Eq. 6's distance (and Eq. 5's for IQL-NDR) is called in the summary, per source.
DISTANCE_NAMES = {"model": "model", "file": "model", "exact": "exact BFS distance", "oracle": "true map's BFS distance",
                  "head": "straight line"}
#: ``plan --prior-from`` names that are sources rather than files.
NAMED_SOURCES = {"oracle": OracleSource, "exact": ExactSource, "head": HeadSource}


@dataclass(frozen=True)
class Predicted:
    """The priors one plan's NDR methods use, and the methods to run after the fallback."""

    region_map: np.ndarray | None = None
    """Region at the map's resolution (report, figures, JSON)."""
    guideline_map: np.ndarray | None = None
    """Guideline at the map's resolution."""
    region: np.ndarray | None = None
    """Region on the planning grid (what the priors use)."""
    guideline: np.ndarray | None = None
    """Guideline on the planning grid."""
    weights: str | None = None
    """What made them: the weights file that served, ``"oracle priors"``, or ``None`` for given arrays."""
    distance: np.ndarray | None = None
    """The source's goal distance on the planning grid (cells), for Eq. 6; ``None``: the straight line."""
    threshold: float | None = None
    """Eq. 7's threshold the judge found (every NDR method of the plan builds its Q-table with it)."""
    methods: tuple[Method, ...] = ()
    """The methods to run (after :func:`~ndrql.pipeline.fallback.fall_back`)."""
    fallbacks: tuple[Fallback, ...] = ()
    """The NDR methods replaced by the fallback."""
    trials: tuple[Trial, ...] = ()
    """The sources asked, in order, with the judge's verdicts."""
    record: dict[str, Any] = field(default_factory=dict)
    """What the JSON says about them: sources, model input, backend, prediction quality, fallback."""
    repredict: Repredict | None = None
    """On a sensed belief map that asks for it (``SenseConfig.predict_again``), served by a model with the unknown
    channel: how it predicts again on a belief grown by sensing (:func:`~ndrql.pipeline.sources.belief_predictor`);
    ``None`` otherwise (nothing is built on plan's path by default)."""


#: Why Eq. 6's mask term is off on a belief map (studies/partial/README.md, "The short runs"): Eq. 7's region joins
#: start and goal on what the planner knows, a hidden wall can cut it, and the mask's bonus then holds the agent
#: against that wall (NDR-QL's priors as on a known map: 2.4x IQL-BFS's steps; without the mask 0.90x).
BELIEF_MASK = ("mask off on a belief map: Eq. 7's region joins start and goal on what is known, and a hidden wall "
               "that cuts it would hold the agent")


def _sources(request: Any, record: dict[str, Any]) -> list[Any]:
    """The request's sources in the order they are asked (loading the model when the policy names it)."""
    out: list[Any] = []
    for name in request.sources:
        if name == "file":
            out.append(GivenSource(request.predictions))
        elif name in NAMED_SOURCES:
            record.setdefault("prior_from", name)
            out.append(NAMED_SOURCES[name]())
        else:
            settings = request.settings
            predictor = load_predictor(request.weights_file, settings.threads, settings.backend, settings.symmetries)
            record["backend"] = predictor.backend_name
            if predictor.graph_file is not None:  # the file that actually runs (an export of the weights)
                record["runs_file"] = str(predictor.graph_file)
            if predictor.input_mode == "grid":
                record["symmetries"] = predictor.symmetries
            out.append(ModelSource(predictor, settings.learned_distance))
    record["policy"] = list(request.sources)
    return out


def judged_config(ms: list[Method], consts: Callable[[str], tuple[QLConfig, PriorConfig]]) -> PriorConfig:
    """The constants of the judge's Eq. 7 search: the first NDR method's on this grid (every NDR method of the
    plan then takes the threshold it found)."""
    ndr = [m for m in ms if m.needs_ndr]
    return consts(ndr[0].name)[1] if ndr else PriorConfig()


def _quality(trials: tuple[Trial, ...], verdict: Any, cells: int) -> dict[str, Any]:
    """The JSON's ``prediction_quality``: the verdict on the priors used (or the last one asked) and every reason."""
    v = verdict
    reasons = [f"{t.source}: {t.reason}" if len(trials) > 1 else str(t.reason) for t in trials if not t.accepted]
    return {"informative": any(t.accepted for t in trials), "source": None if not trials else
            next((t.source for t in trials if t.accepted), trials[-1].source),
            "threshold": None if v is None else v.threshold, "min_threshold": min_threshold(cells),
            "region_cover": None if v is None else v.cover,
            "guideline_on_obstacles": None if v is None else v.guideline_on_obstacles,
            "route_ratio": None if v is None else v.route_ratio, "reasons": reasons if not any(
                t.accepted for t in trials) else []}


def predict_for(request: Any, grid: PlanningGrid, clock: StageClock,
                consts: Callable[[str], tuple[QLConfig, PriorConfig]], truth: np.ndarray | None = None) -> Predicted:
    """The priors the NDR methods of ``request`` (a :class:`~ndrql.pipeline.request.PlanRequest`) use on ``grid``
    (what the planner knows; ``truth``: the true grid's blocked cells where part of the map is unknown, for the
    oracle), and the methods to run (module docstring). Times the ``load`` and ``predict`` stages on ``clock``."""
    ms = [get_method(m) for m in request.methods]
    settings = request.settings
    record: dict[str, Any] = {}
    budget = settings.predict_budget
    with clock.stage("load"):
        sources = _sources(request, record)
    deadline = None if budget is None else time.perf_counter() + float(budget)  # the prediction's, after loading
    belief = getattr(request, "belief", None)
    problem = SourceInput(grid, request.grid_map, request.start, request.goal, partial=belief is not None, truth=truth,
                          unknown=None if belief is None else unknown_cells(belief.unknown, grid))
    cfg = judged_config(ms, consts)
    with clock.stage("predict"):
        chosen, trials, first = consult(sources, problem, cfg, deadline,
                                        max_route_ratio=float("inf") if problem.partial else None)
    record["sources"] = [t.to_dict() for t in trials]
    used = chosen if chosen is not None else first
    priors, verdict = used if used is not None else (None, None)
    if priors is not None:  # the named source that gave the priors (a policy may ask the model first)
        if priors.source in NAMED_SOURCES:
            record["prior_from"] = priors.source
        else:
            record.pop("prior_from", None)
    quality = _quality(trials, verdict, max(grid.shape))
    record["prediction_quality"] = quality
    fallback = settings.fallback
    if priors is None and fallback is None:  # nothing to keep: every source gave nothing within the budget
        fallback = "IQL-BFS"
        quality["reasons"].append("no prediction to keep with fallback none")
    ran, swaps = fall_back(ms, quality, fallback)
    if swaps:
        record["fallback"] = {"requested": [f.requested for f in swaps], "ran": swaps[0].ran, "reasons": quality["reasons"]}
    if priors is None or not any(m.needs_ndr for m in ran):
        return Predicted(methods=tuple(ran), fallbacks=tuple(swaps), trials=trials, record=record,
                         region_map=None if priors is None else priors.region_map,
                         guideline_map=None if priors is None else priors.guideline_map)
    needs_guide = [m.name for m in ran if m.needs_guideline]
    if priors.guideline is None and needs_guide:
        raise NdrqlError(f"{', '.join(needs_guide)} need the guideline prediction, which "
                         f"{priors.weights or 'the predictions'} do not provide (model without guideline decoder)")
    record["model_input"] = priors.info
    if "runs_file" in priors.info:  # a companion's graph may have run instead
        record["runs_file"] = priors.info.pop("runs_file")
    if "prior_grid" in priors.info:
        record["prior_grid"] = priors.info["prior_grid"]
    distance = priors.distance
    if any(m.needs_distance for m in ran):  # Eq. 6's distance (NDR-QI), and Eq. 5's for IQL-NDR
        record["qi_distance"] = DISTANCE_NAMES.get(priors.source, "model") if distance is not None else "straight line"
    weights = ORACLE_NAME if priors.source == "oracle" else priors.weights
    threshold = verdict.threshold if verdict is not None else None
    if problem.partial:  # no Eq. 6 mask on a belief map (BELIEF_MASK)
        threshold = None
        if any(m.n_qi for m in ran):
            record["qi_mask"] = BELIEF_MASK
    sensing = getattr(request, "sensing", None)
    again = None  # only a sensed plan that asks for it predicts again (SenseConfig.predict_again)
    if problem.partial and priors.source == "model" and sensing is not None and sensing.predict_again:
        again = belief_predictor(next((s for s in sources if s.name == "model"), None), grid)
    return Predicted(priors.region_map, priors.guideline_map, priors.region, priors.guideline, weights, distance,
                     threshold, tuple(ran), tuple(swaps), trials, record, again)
