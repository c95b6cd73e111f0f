"""One plan is one value: :class:`PlanRequest`, built and validated in one place, :func:`build_request`.

``ndrql plan`` turns its flags into a request, :func:`ndrql.plan` and :func:`ndrql.solve` build one
from their keywords (or take one as it is), the scenario batch, ``ndrql demo`` and the environment's
``ndr`` prior build theirs the same way; :func:`ndrql.api.solve` runs it. Whatever the door, the same
request makes the same plan.

What :func:`build_request` decides, once:

- the map (read here, from a file, a :class:`~ndrql.maps.grid.GridMap` or an array) and its kind: a
  user's map (``map``) or a dataset sample (``sample``, given with ``sample=`` its record);
- start and goal in checked map pixels, from pixels, metres (maps with a resolution) or scenario K of
  a MovingAI ``.scen`` (``scen="arena.map.scen:K"`` or ``scen_index=K``); a point given two ways is an error;
- the settings' input-dependent defaults (:class:`~ndrql.pipeline.settings.PlanSettings` leaves them
  unset): grid ``safe`` with ``size auto``, smoothing on and the ``IQL`` fallback for one method on a
  user's map; the paper's ``area`` 50x50 grid, no smoothing and no fallback on a dataset sample; no
  fallback when several methods are compared;
- the weights: as named, else ``$NDRQL_WEIGHTS`` or ``general``; on a belief map with none named, the shipped
  ``belief`` weights when installed (:func:`~ndrql.model.weights.plan_weights`);
- the constants: the preset (default :func:`~ndrql.planning.preset.plan_default_preset` of the file
  the weights resolve to, ``$NDRQL_WEIGHTS`` included; ``belief`` on a belief map), with the fields the caller set explicitly
  (``ql={...}``, ``priors={...}``) on top of every method's entry. A field set to its default value is
  still set: ``priors={"guideline_ties": 0.0}`` turns a preset's value back to the paper's.
"""

from __future__ import annotations

import dataclasses
import os
import time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from ndrql.errors import NdrqlError, PointError, brief
from ndrql.limits import check_finite
from ndrql.maps.grid import GridMap
from ndrql.maps.readers import IMAGE_SUFFIXES, YAML_SUFFIXES
from ndrql.model.weights import plan_weights, resolve_weights, weights_label
from ndrql.maps.belief import Belief
from ndrql.pipeline.belief import check_points_known, read_belief
from ndrql.pipeline.sensing import SenseConfig, sense_config
from ndrql.pipeline.problem import Point, check_map_size, place_points, read_map
from ndrql.pipeline.runs import methods_named, seeds_given
from ndrql.pipeline.settings import PlanSettings
from ndrql.pipeline.sources import SOURCE_NAMES, default_policy
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import get_method
from ndrql.planning.preset import Preset, load_preset, plan_default_preset

#: Kinds of map a request plans on: a user's map, or a dataset sample (the paper's setting by default).
KINDS = ("map", "sample")
#: The method an NDR method falls back to on a user's map when every prior source is rejected: the exact-distance
#: prior (IQL with Eq. 5 on the BFS distance), the floor no prediction should fall below (issue 53).
DEFAULT_FALLBACK = "IQL-BFS"
#: Setting fields whose ``None`` is a value, not "unset": no fallback, no time limit.
NONE_MEANS = ("fallback", "predict_budget")
#: Q-learning constants a caller may set (``ql={...}``, the ``plan`` flags of the same names).
QL_FIELDS: tuple[str, ...] = ("alpha", "epsilon", "gamma", "max_steps", "max_episodes", "window",
                              "reward_collision", "reward_goal", "reward_revisit")
#: Prior constants a caller may set (``priors={...}``).
PRIOR_FIELDS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(PriorConfig))


@dataclass(frozen=True, eq=False)
class PlanRequest:
    """Everything one plan needs, resolved and checked (:func:`build_request` makes it)."""

    grid_map: GridMap = field(repr=False)
    """The map as read (``True`` = obstacle)."""
    kind: str
    """``map`` (a user's map) or ``sample`` (a dataset sample)."""
    start: Point
    """Start in map pixels ``(row, col)``, on a free pixel."""
    goal: Point
    """Goal in map pixels ``(row, col)``, on a free pixel."""
    methods: tuple[str, ...]
    """Methods asked for, each once, by their registry names."""
    seeds: tuple[int, ...]
    """Seeds, the same for every method."""
    settings: PlanSettings
    """Grid rule and size, robot radius, smoothing, fallback, limits: every default decided."""
    preset: Preset = field(repr=False)
    """Each method's constants: the preset with the explicitly set fields on every entry."""
    weights: str | None = None
    """The model's weights as given (``paper``, ``general``, a file, ``None``: ``$NDRQL_WEIGHTS`` or the default)."""
    weights_file: str | None = None
    """The file they resolve to (the preset follows it)."""
    sources: tuple[str, ...] = ("model",)
    """The prior sources the NDR methods consult, in order (:mod:`ndrql.pipeline.sources`): decided by
    :func:`build_request` (:func:`~ndrql.pipeline.sources.default_policy` unless the caller names one)."""
    predictions: Any = field(default=None, repr=False)
    """Predictions instead of the model: ``"oracle"``, ``(region, guideline)`` or a
    :class:`~ndrql.pipeline.predictions.GivenPredictions`; ``None``: the model."""
    start_yaw: float | None = None
    """Yaw of the first pose (radians), from a world start."""
    goal_yaw: float | None = None
    """Yaw of the last pose (radians), from a world goal."""
    set_fields: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    """The constants set explicitly (``{"ql": {...}, "priors": {...}}``), for the record."""
    info: Mapping[str, Any] = field(default_factory=dict)
    """Where the problem came from (map file, dataset sample, scenario, prediction file)."""
    map_seconds: float = field(default=0.0, repr=False)
    """Wall time spent reading the map and placing the points."""
    belief: Belief | None = field(default=None, repr=False)
    """What the planner knows of the map (``hide=``, ``unknown="free"``; :mod:`ndrql.pipeline.belief`): the priors
    read it, the agent learns on ``grid_map``; ``None``: the planner knows the map."""
    unknown_rule: str = "obstacle"
    """How a ROS map's unknown space counts: ``obstacle`` (``map_server``'s reading) or ``free`` (Nav2's ``allow_unknown``)."""
    sensing: SenseConfig | None = None
    """Revealed as it moves (``sense=R``; :mod:`ndrql.pipeline.sensing`): radius in planning cells, recomputation interval."""

    def constants(self, method: str, grid_side: int | None = None) -> tuple[QLConfig, PriorConfig]:
        """``(QLConfig, PriorConfig)`` of ``method`` on a grid of ``grid_side`` cells per side (a per-grid-size
        preset takes its nearest entry, :meth:`~ndrql.planning.preset.Preset.setting`)."""
        return self.preset.configs(method, grid=grid_side)

    @property
    def needs_priors(self) -> bool:
        """Whether a method asks for NDR priors (region, guideline), from whichever :attr:`sources`."""
        return any(get_method(m).needs_ndr for m in self.methods)

    def to_dict(self) -> dict[str, Any]:
        """The request as plain types (the JSON's ``request``)."""
        s = dataclasses.asdict(self.settings)
        return {"kind": self.kind, "start": list(self.start), "goal": list(self.goal), "methods": list(self.methods),
                "seeds": list(self.seeds) if len(self.seeds) <= 20 else [self.seeds[0], "...", self.seeds[-1]],
                "settings": s, "preset": self.preset.name, "set": {k: dict(v) for k, v in self.set_fields.items()},
                "weights": self.weights_file,
                **({"hide": {"kind": self.belief.kind, "unknown_px": int(self.belief.unknown.sum())},
                    "unknown": self.unknown_rule} if self.belief is not None else {}),
                **({"sense": dataclasses.asdict(self.sensing)} if self.sensing is not None else {})}


def _overrides(values: Mapping[str, Any] | None, names: tuple[str, ...], what: str) -> dict[str, Any]:
    out = dict(values or {})
    unknown = [k for k in out if k not in names]
    if unknown:
        raise NdrqlError(f"unknown {what} constant {unknown[0]!r}; valid: {', '.join(names)}")
    return out


def _constants(preset: Any, config: QLConfig | None, prior_config: PriorConfig | None, ql: Mapping[str, Any] | None,
               priors: Mapping[str, Any] | None, weights_file: str | None,
               partial: bool = False) -> tuple[Preset, PriorConfig, dict]:
    """The preset with the explicitly set fields, and the prior constants the prediction is judged with; no preset
    given: :func:`~ndrql.planning.preset.plan_default_preset` (``belief`` on a belief map, ``partial``)."""
    q_set = _overrides(ql, QL_FIELDS, "Q-learning")
    p_set = _overrides(priors, PRIOR_FIELDS, "prior")
    if config is not None or prior_config is not None:  # a whole config is every one of its fields set
        if preset is not None:
            raise NdrqlError("give a preset with ql={...}/priors={...} for the fields to change, or whole configs "
                             "(config=, prior_config=) without a preset, not both")
        if config is not None:
            q_set = {**{k: getattr(config, k) for k in QL_FIELDS}, **q_set}
        if prior_config is not None:
            p_set = {**{k: getattr(prior_config, k) for k in PRIOR_FIELDS}, **p_set}
    label = weights_label(weights_file) if weights_file is not None else None
    base = load_preset(preset if preset is not None else plan_default_preset(label, partial))
    try:
        quality = dataclasses.replace(PriorConfig(), **p_set)
        dataclasses.replace(QLConfig(), **q_set)
    except (TypeError, ValueError) as exc:
        raise NdrqlError(f"bad option: {exc}") from None
    return base.with_overrides(q_set, p_set), quality, {"ql": q_set, "priors": p_set}


def _settings(settings: PlanSettings | None, kind: str, n_methods: int, given: Mapping[str, Any]) -> PlanSettings:
    """``settings`` with the fields given (not ``None``) on top, and the input-dependent defaults decided."""
    base = settings if settings is not None else PlanSettings()
    try:
        s = dataclasses.replace(base, **{k: v for k, v in given.items() if v is not None or k in NONE_MEANS})
    except TypeError as exc:
        raise NdrqlError(f"bad option: {exc}") from None
    sample = kind == "sample"
    grid = s.grid or ("area" if sample else "safe")
    smooth = s.smooth if s.smooth is not None else not sample
    fallback = s.fallback
    if fallback == "auto":
        fallback = None if sample or n_methods > 1 else DEFAULT_FALLBACK
    return dataclasses.replace(s, grid=grid, smooth=smooth, fallback=fallback)


def request_settings(settings: PlanSettings | None = None, *, sample: Mapping[str, Any] | None = None,
                     methods: Sequence[str] | str = ("NDR-QL",), **fields: Any) -> PlanSettings:
    """The settings :func:`build_request` decides for these arguments (its other keywords are ignored)."""
    given = {k: v for k, v in fields.items() if k in {f.name for f in dataclasses.fields(PlanSettings)}}
    return _settings(settings, "sample" if sample is not None else "map", len(methods_named(methods)), given)


def _check_reader_options(source: Any, invert: bool, threshold: float, crop: bool) -> None:
    """Reader options that the map would ignore are errors (a ROS map has its own thresholds)."""
    try:
        check_finite(threshold, "--threshold")
    except ValueError as exc:
        raise NdrqlError(str(exc)) from None
    path = os.fspath(source).lower() if isinstance(source, (str, os.PathLike)) else None
    image, ros = (path is not None and path.endswith(IMAGE_SUFFIXES)), (path is not None and path.endswith(YAML_SUFFIXES))
    given = [f for f, v in (("invert", invert), ("threshold", threshold != 128)) if v]
    if given and not image:
        raise NdrqlError(f"{' and '.join(given)} read image files (dark = obstacle); this map is not one "
                         f"(a ROS map's thresholds are in its .yaml)")
    if crop and not ros:
        raise NdrqlError("crop cuts a ROS map to its known cells; this map is not a ROS .yaml")


def split_scen(scen: str | os.PathLike | None, index: int | None) -> tuple[str | None, int | None]:
    """``scen="FILE:K"`` as ``(FILE, K)`` (a trailing ``:K`` is the scenario when ``FILE:K`` is not itself a
    file); ``scen_index`` and ``:K`` together are an error."""
    if scen is None:
        if index is not None:
            raise NdrqlError("a scenario number needs a scenario file (--scen FILE, scen=)")
        return None, None
    text = os.fspath(scen)
    head, sep, tail = text.rpartition(":")
    k = None
    if sep and tail.strip().lstrip("+-").isdigit() and len(tail) <= 12 and not os.path.isfile(text):
        text, k = head, int(tail)
    if k is not None and index is not None:
        raise NdrqlError(f"give the scenario as {text}:{k} or as the index {index}, not both")
    return text, k if k is not None else index


#: Settings that only the network uses: set to anything but their default, they ask for the model's priors.
MODEL_SETTINGS = ("backend", "threads", "symmetries", "learned_distance")


def request_sources(predictions: Any, weights: Any, kind: str, partial: bool,
                    settings: PlanSettings | None = None) -> tuple[str, ...]:
    """The sources a request consults: the one named (``predictions`` ``"model"``, ``"exact"``, ``"oracle"``,
    ``"head"``), the given arrays (``"file"``), the model when ``weights`` name one or a setting only the model uses
    (:data:`MODEL_SETTINGS`) differs from its default, else :func:`~ndrql.pipeline.sources.default_policy`."""
    if isinstance(predictions, str):
        return (predictions,)
    if predictions is not None:
        return ("file",)
    plain = PlanSettings()
    if weights is not None or (settings is not None and any(getattr(settings, k) != getattr(plain, k)
                                                            for k in MODEL_SETTINGS)):
        return ("model",)
    return default_policy(kind, partial, partial and plan_weights(None, True) is not None)


#: What the API's object arguments may be (anything else is one NdrqlError, never an AttributeError deep inside).
_KINDS: dict[str, tuple[type, ...]] = {"weights": (str, os.PathLike), "preset": (str, os.PathLike, Preset),
                                       "config": (QLConfig,), "prior_config": (PriorConfig,), "ql": (Mapping,),
                                       "priors": (Mapping,), "scen": (str, os.PathLike), "invert": (bool,),
                                       "crop": (bool,)}


def _check_kinds(**given: Any) -> None:
    for name, value in given.items():
        if value is not None and not isinstance(value, _KINDS[name]):
            want = " or ".join("a path" if k is os.PathLike else "a mapping" if k is Mapping else
                               "text" if k is str else "True or False" if k is bool else f"a {k.__name__}" for k in _KINDS[name])
            raise NdrqlError(f"{name} must be {want}, got {brief(value)}")


def build_request(
    map_source: Any,
    start: Sequence[int] | None = None,
    goal: Sequence[int] | None = None,
    *,
    start_world: Sequence[float] | None = None,
    goal_world: Sequence[float] | None = None,
    scen: str | os.PathLike | None = None,
    scen_index: int | None = None,
    methods: Sequence[str] | str = ("NDR-QL",),
    seeds: Sequence[int] | int = (0,),
    weights: str | os.PathLike | None = None,
    predictions: Any = None,
    preset: Any = None,
    ql: Mapping[str, Any] | None = None,
    priors: Mapping[str, Any] | None = None,
    config: QLConfig | None = None,
    prior_config: PriorConfig | None = None,
    settings: PlanSettings | None = None,
    sample: Mapping[str, Any] | None = None,
    invert: bool = False,
    threshold: float = 128,
    crop: bool = False,
    hide: Any = None,
    unknown: str | None = None,
    sense: float | None = None,
    sense_every: int | None = None,
    info: Mapping[str, Any] | None = None,
    **setting_fields: Any,
) -> PlanRequest:
    """The one place a plan is defaulted and validated (module docstring); raises :class:`NdrqlError`.

    ``map_source``: a map file (image, ROS ``.yaml``, MovingAI ``.map``, ``.npy``), a :class:`GridMap`
    or a 2-D array (non-zero = obstacle). ``start``/``goal``: ``(row, col)`` map pixels;
    ``start_world``/``goal_world``: ``(x, y[, yaw])`` metres on a map with a resolution; ``scen``: a
    MovingAI ``.scen`` (``FILE:K`` or ``scen_index=K``, default 0) whose scenario gives both points.
    ``sample``: the record of a dataset sample (``{"sample": {...}}``): the request is then of kind
    ``sample`` and takes the paper's setting by default. ``ql``/``priors``: constants set on top of the
    preset; ``config``/``prior_config``: whole configs (every field set; not with ``preset``).
    ``setting_fields``: any field of :class:`PlanSettings` (``grid``, ``size``, ``robot_radius``, ...),
    set on top of ``settings``; ``None`` leaves it unset, except ``fallback=None``: no fallback.
    ``hide``: a mask of the map's size (``.npy``, image or array; non-zero = unknown to the planner, whose
    priors then count it free while the agent learns on the map) or a :class:`~ndrql.maps.belief.Belief`;
    ``unknown``: ``obstacle`` (default) or ``free`` for a ROS map's unknown space (:mod:`ndrql.pipeline.belief`).
    ``sense``: revealed as it moves, cells within ``sense`` planning cells of the agent become known and the
    priors are rebuilt every ``sense_every`` episodes (:mod:`ndrql.pipeline.sensing`; needs a belief).
    """
    t0 = time.perf_counter()
    kind = "sample" if sample is not None else "map"
    not_options = [k for k in setting_fields if k not in {f.name for f in dataclasses.fields(PlanSettings)}]
    if not_options:
        raise NdrqlError(f"unknown plan option {not_options[0]!r}")
    _check_kinds(weights=weights, preset=preset, config=config, prior_config=prior_config, ql=ql, priors=priors,
                 scen=scen, invert=invert, crop=crop)
    ms = tuple(m.name for m in methods_named(methods))
    seed_list = tuple(seeds_given(seeds))
    s = _settings(settings, kind, len(ms), setting_fields)
    scen_file, index = split_scen(scen, scen_index)
    if scen_file is not None:
        given = [n for n, v in (("start", start), ("goal", goal), ("start_world", start_world),
                                ("goal_world", goal_world)) if v is not None]
        if given:
            raise PointError(f"a scenario gives start and goal; drop {' and '.join(given)} (or drop the scenario)")
        if kind == "sample":
            raise NdrqlError("a scenario needs a map file (MovingAI .map), not a dataset sample")
    _check_reader_options(map_source, invert, threshold, crop)
    grid_map = read_map(map_source, invert=invert, threshold=threshold, crop=crop, max_pixels=s.max_map_pixels)
    if scen_file is not None and not str(grid_map.source).lower().endswith(".map"):
        raise NdrqlError(f"a MovingAI scenario goes with its MovingAI .map; {grid_map.source} is not one")
    check_map_size(grid_map, s)
    grid_map, belief, unknown_rule = read_belief(map_source, grid_map, hide=hide, unknown=unknown, crop=crop,
                                                 max_pixels=s.max_map_pixels)
    record: dict[str, Any] = {"source": grid_map.source, **dict(sample or {}), **dict(info or {})}
    if kind == "map" and scen_file is None:
        missing = [n for n, px, w in (("start", start, start_world), ("goal", goal, goal_world)) if px is None and w is None]
        if missing:
            raise PointError(f"no {' and '.join(missing)} given: (row, col) map pixels, ({'/'.join(missing)})_world "
                             f"(x, y) metres on maps with a resolution, or a scenario")
    p_start, p_goal, start_yaw, goal_yaw = place_points(grid_map, start, goal, scen=scen_file,
                                                        scen_index=0 if index is None else int(index),
                                                        start_world=start_world, goal_world=goal_world, info=record)
    check_points_known(belief, p_start, p_goal)
    sensing = sense_config(sense, sense_every, belief is not None)
    if predictions is not None and not any(get_method(m).needs_ndr for m in ms):
        raise NdrqlError(f"predictions are given but none of {', '.join(ms)} uses them (N-C, N-Q, NDR-QL, IQL-NDR do)")
    if isinstance(predictions, str) and predictions not in SOURCE_NAMES[:-1]:
        raise NdrqlError(f"predictions must be (region, guideline) arrays, a prediction file's contents, or one of "
                         f"{', '.join(SOURCE_NAMES[:-1])}, got {predictions[:40]!r}")
    if predictions not in (None, "model") and weights is not None:
        raise NdrqlError("give either weights or predictions (--weights or --prior-from), not both")
    sources = request_sources(predictions, weights, kind, belief is not None, s)
    predictions = None if predictions == "model" else predictions
    uses_model = "model" in sources
    asked = plan_weights(weights, belief is not None) if uses_model else weights  # a belief map: the belief weights
    weights_file = str(resolve_weights(asked)) if uses_model or preset is None else None
    preset_obj, _, set_fields = _constants(preset, config, prior_config, ql, priors, weights_file, belief is not None)
    record["preset"] = preset_obj.name
    return PlanRequest(grid_map=grid_map, belief=belief, unknown_rule=unknown_rule, sensing=sensing, sources=sources, kind=kind, start=p_start, goal=p_goal, methods=ms, seeds=seed_list,
                       settings=s, preset=preset_obj, weights=None if weights is None else
                       os.fspath(weights), weights_file=weights_file if uses_model else None, predictions=predictions,
                       start_yaw=start_yaw, goal_yaw=goal_yaw, set_fields=set_fields, info=record,
                       map_seconds=time.perf_counter() - t0)


__all__ = ["DEFAULT_FALLBACK", "KINDS", "PRIOR_FIELDS", "PlanRequest", "QL_FIELDS", "build_request", "request_settings",
           "split_scen"]
