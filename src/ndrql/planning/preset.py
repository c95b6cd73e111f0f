"""Presets: named, versioned sets of Q-learning and prior constants, per method.

A preset is a JSON file (format ``ndrql-preset``, ``version`` 1) holding, for each method, the
values that differ from the frozen configs' defaults (:class:`~ndrql.planning.config.QLConfig`,
:class:`~ndrql.planning.config.PriorConfig`). Two ship with the package, in
``ndrql/planning/presets/``:

- ``spec``: the paper-reproduction constants (alpha 0.1, epsilon 0.2, gamma 0.95; r_max 5, G 10,
  omega 0.5, mask -10, threshold from 0.99 in steps of 0.01) for every method; the reproduction
  commands use it by default.
- ``tuned``: each method's constants from a hyper-parameter search on held-out training maps of the
  paper's dataset and its 50x50 grids, for the ``paper`` weights (``ndrql tune``), with the search's
  budget and a check on fresh seeds recorded beside them.
- ``general``: the same search for the ``general`` weights on held-out generated maps of every family,
  once per planning-grid size (``ndrql tune --maps generated --grid N``): a ``grids`` entry per size.
- ``belief``: ``general`` with NDR-QL's and IQL-BFS's constants searched on belief maps (priors from the belief
  model or the belief's BFS on what the planner knows, Eq. 6's mask off, learning on the true map;
  ``studies/partial/tune_belief.py``), grid 100's entries also above 100 cells; every other method's entry is
  general's. ``plan`` uses it on a belief map when no preset is given.

A preset file looks like (every constant of :data:`PRESET_FIELDS` is written out; a missing one
takes the config's default)::

    {"format": "ndrql-preset", "version": 1, "name": "tuned",
     "default": {"ql": {}, "priors": {}},
     "methods": {"NDR-QL": {"ql": {"alpha": 0.3}, "priors": {"r_max": 9.0}}},
     "fallback": "NDR-QL", "plan_default": true, "meta": {...}}

A method missing from ``methods`` uses the entry named by ``fallback`` (when given), else
``default``. Version 2 adds an optional ``"grids": {"50": {"NDR-QL": {...}, ...}, "100": {...}}``:
constants per planning-grid size. A problem on a grid of ``n`` cells takes the entry whose size is
nearest to ``n`` on a log scale (:func:`nearest_grid`: with entries 50 and 100, grids up to 70 take
50's, larger ones 100's); a method that entry does not list takes the next nearest entry that lists
it, a run whose grid is unknown the smallest size's; a method no entry lists falls back to ``methods``. Only the search's constants may appear (:data:`PRESET_FIELDS`); anything else is a
:class:`PresetError`. Explicit flags or arguments override a preset's values.

Layering: depends on :mod:`ndrql.planning.config`, :mod:`ndrql.planning.methods` and
:mod:`ndrql.io` only.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any, Mapping

from ndrql.errors import NdrqlError, brief
from ndrql.io import note_input, write_json
from ndrql.io.text import MAX_TEXT_BYTES, load_json, read_capped
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import get_method

FORMAT = "ndrql-preset"
#: Version of the preset file format this module writes (it reads 1 and 2; 2 added ``grids``).
VERSION = 2
READS = (1, 2)
#: Presets shipped with the package, by name.
BUILTIN = ("spec", "tuned", "general", "belief")
#: The preset ``plan`` uses on a map the planner does not fully know (``--hide``) when none is given.
BELIEF_PRESET = "belief"
#: The constants a preset may set, per config: what the search explores, and the choices beyond the
#: paper that a preset fixes per grid (region_dilation, guideline_ties: docs/results.md#transfer;
#: region_distance: studies/large_view/history.md#distance-through-the-region;
#: thd_tail: docs/method.md#4-the-priors-eqs-2-7).
PRESET_FIELDS: dict[str, tuple[str, ...]] = {
    "ql": ("alpha", "epsilon", "gamma"),
    "priors": ("r_max", "g_row", "g_col", "omega_crf", "omega_qi", "mask_low", "thd_start", "thd_step",
               "region_dilation", "guideline_ties", "region_distance", "thd_tail"),
}


#: Key of a ``grids`` entry that holds one setting for every method (in memory only: :meth:`Preset.only`).
ANY = "*"


class PresetError(NdrqlError):
    """A preset name is unknown, or a preset file is missing, malformed or of another version."""


@dataclass(frozen=True)
class MethodSetting:
    """The constants one method runs with."""

    ql: QLConfig = field(default_factory=QLConfig)
    """Q-learning constants (Eq. 1's update; SPEC-style defaults where the preset is silent)."""
    priors: PriorConfig = field(default_factory=PriorConfig)
    """Prior constants (Eqs. 2-7)."""

    def values(self) -> dict[str, dict[str, float]]:
        """Every constant a preset sets (:data:`PRESET_FIELDS`), as stored in a preset file."""
        return configs_dict(self.ql, self.priors)


@dataclass(frozen=True)
class Preset:
    """A named set of constants per method (module docstring)."""

    name: str
    """``spec``, ``tuned`` or the file's own name."""
    default: MethodSetting = field(default_factory=MethodSetting)
    """Constants of a method the preset does not list (and no fallback)."""
    methods: Mapping[str, MethodSetting] = field(default_factory=dict)
    """Constants per method name."""
    fallback: str | None = None
    """Entry of ``methods`` used for a method not listed (e.g. the ablation rows of Table 2)."""
    plan_default: bool = False
    """Whether ``ndrql plan`` uses this preset when no ``--preset`` is given (it won on validation maps)."""
    meta: Mapping[str, Any] = field(default_factory=dict)
    """Provenance: search budget, study, validation check (free-form, JSON)."""
    source: str = ""
    """Where it was read from."""
    grids: Mapping[int, Mapping[str, MethodSetting]] = field(default_factory=dict)
    """Constants per planning-grid size (cells per side), then per method (module docstring)."""

    def setting(self, method: str, grid: int | None = None) -> MethodSetting:
        """The constants of ``method`` on a grid of ``grid`` cells per side (``None``: unknown): the entry
        of :attr:`grids` nearest in size that lists it (unknown grid: the smallest size's), else its entry
        in :attr:`methods`; then the same for the method whose constants it takes (``Method.constants``:
        IQL-BFS takes IQL's); else the fallback entry, else ``default``."""
        try:
            m = get_method(method)
            names = [m.name] + ([m.constants] if m.constants else [])  # IQL-BFS: its own entry, else IQL's
        except NdrqlError:  # a table's own row (e.g. Table 2's D-C+N-C) is not a registry method
            names = [method]
        for name in names:
            if self.grids:
                sizes = sorted(self.grids)
                if grid is not None:
                    sizes.sort(key=lambda n: (abs(math.log(max(grid, 1) / n)), n))
                for size in sizes:
                    entry = self.grids[size]
                    if name in entry or ANY in entry:  # ANY: an ablation's one setting for every row (:meth:`only`)
                        return entry.get(name, entry.get(ANY))
            if name in self.methods:
                return self.methods[name]
        if self.fallback is not None:
            return self.methods[self.fallback]
        return self.default

    def configs(self, method: str, ql: Mapping[str, Any] | None = None,
                priors: Mapping[str, Any] | None = None, grid: int | None = None) -> tuple[QLConfig, PriorConfig]:
        """``(QLConfig, PriorConfig)`` of ``method`` (on a grid of ``grid`` cells), explicit ``ql``/``priors`` on top."""
        s = self.setting(method, grid)
        try:
            return replace(s.ql, **dict(ql or {})), replace(s.priors, **dict(priors or {}))
        except ValueError as exc:
            raise NdrqlError(f"bad option: {exc}") from None

    def with_overrides(self, ql: Mapping[str, Any] | None = None, priors: Mapping[str, Any] | None = None) -> "Preset":
        """This preset with ``ql``/``priors`` values set on every entry (explicit flags win over a preset)."""
        if not ql and not priors:
            return self
        try:
            def over(s: MethodSetting) -> MethodSetting:
                return MethodSetting(replace(s.ql, **dict(ql or {})), replace(s.priors, **dict(priors or {})))

            return replace(self, default=over(self.default), methods={m: over(s) for m, s in self.methods.items()},
                           grids={n: {m: over(s) for m, s in e.items()} for n, e in self.grids.items()})
        except ValueError as exc:
            raise NdrqlError(f"bad option: {exc}") from None

    def only(self, method: str) -> "Preset":
        """This preset with ``method``'s constants for every method (an ablation at fixed constants)."""
        grids = {n: {ANY: e[get_method(method).name]} for n, e in self.grids.items() if get_method(method).name in e}
        return replace(self, default=self.setting(method), methods={}, fallback=None, grids=grids)

    def describe(self) -> str:
        """One line: name, where from, and how many methods it sets."""
        listed = ", ".join(dict.fromkeys([*self.methods, *(m for e in self.grids.values() for m in e)])) or \
            "every method alike"
        per_grid = f"; per grid size {', '.join(map(str, sorted(self.grids)))}" if self.grids else ""
        return f"preset {self.name} ({listed}{per_grid})"


def nearest_grid(sizes: "list[int] | tuple[int, ...]", n: int) -> int:
    """The size in ``sizes`` nearest to ``n`` on a log scale (a tie goes to the smaller size)."""
    if n < 1:
        raise NdrqlError(f"grid size must be >= 1, got {n}")
    return min(sorted(sizes), key=lambda s: abs(math.log(n / s)))


def _setting(obj: Any, where: str) -> MethodSetting:
    if not isinstance(obj, dict):
        raise PresetError(f"{where}: expected a mapping with 'ql' and 'priors', got {brief(obj)}")
    unknown = set(obj) - set(PRESET_FIELDS)
    if unknown:
        raise PresetError(f"{where}: unknown part {brief(sorted(unknown)[0])}; valid: ql, priors")
    parts = {}
    for part, cls in (("ql", QLConfig), ("priors", PriorConfig)):
        values = obj.get(part, {})
        if not isinstance(values, dict):
            raise PresetError(f"{where}.{part}: expected a mapping, got {brief(values)}")
        for k, v in values.items():
            if k not in PRESET_FIELDS[part]:
                raise PresetError(f"{where}.{part}: {brief(k)} cannot be set by a preset; valid: "
                                  f"{', '.join(PRESET_FIELDS[part])}")
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise PresetError(f"{where}.{part}.{k}: expected a finite number, got {brief(v)}")
        try:
            parts[part] = cls(**{k: float(v) for k, v in values.items()})
        except ValueError as exc:
            raise PresetError(f"{where}.{part}: {exc}") from None
    return MethodSetting(parts["ql"], parts["priors"])


def preset_from_dict(data: Any, source: str = "") -> Preset:
    """Validate a parsed preset file (module docstring) and build the :class:`Preset`."""
    where = source or "preset"
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise PresetError(f"{where}: not an ndrql preset (expected \"format\": \"{FORMAT}\")")
    if data.get("version") not in READS:
        raise PresetError(f"{where}: preset version {brief(data.get('version'))}; this ndrql reads versions "
                          f"{', '.join(map(str, READS))}")
    name = data.get("name", Path(source).stem if source else "preset")
    if not isinstance(name, str) or not name:
        raise PresetError(f"{where}: 'name' must be a non-empty string")
    methods_in = data.get("methods", {})
    if not isinstance(methods_in, dict):
        raise PresetError(f"{where}: 'methods' must be a mapping of method name to constants")

    methods = _method_settings(methods_in, f"{where}: methods")
    grids_in = data.get("grids", {}) if data.get("version") >= 2 else {}
    if not isinstance(grids_in, dict):
        raise PresetError(f"{where}: 'grids' must be a mapping of grid size to methods")
    grids = {}
    for key, val in grids_in.items():
        if not (isinstance(key, str) and key.isdigit() and int(key) >= 1):
            raise PresetError(f"{where}: grids: {brief(key)} is not a grid size (cells per side, e.g. \"50\")")
        if not isinstance(val, dict):
            raise PresetError(f"{where}: grids.{key} must be a mapping of method name to constants")
        grids[int(key)] = _method_settings(val, f"{where}: grids.{key}")
    fallback = data.get("fallback")
    if fallback is not None and fallback not in methods:
        raise PresetError(f"{where}: fallback {brief(fallback)} is not one of the preset's methods")
    plan_default = data.get("plan_default", False)
    if not isinstance(plan_default, bool):
        raise PresetError(f"{where}: 'plan_default' must be true or false")
    meta = data.get("meta", {})
    return Preset(name=name, default=_setting(data.get("default", {}), f"{where}: default"), methods=methods,
                  fallback=fallback, plan_default=plan_default, meta=meta if isinstance(meta, dict) else {},
                  source=source, grids=grids)


def _method_settings(obj: dict, where: str) -> dict[str, MethodSetting]:
    out = {}
    for key, val in obj.items():
        try:
            m = get_method(key).name
        except NdrqlError as exc:
            raise PresetError(f"{where}: {exc}") from None
        out[m] = _setting(val, f"{where}.{m}")
    return out


def preset_to_dict(p: Preset) -> dict[str, Any]:
    """The JSON form of ``p`` (what :func:`preset_from_dict` reads; version 1 when it has no ``grids``)."""
    out = {"format": FORMAT, "version": VERSION if p.grids else 1, "name": p.name, "default": p.default.values(),
           "methods": {m: s.values() for m, s in p.methods.items()}}
    if p.grids:
        out["grids"] = {str(n): {m: s.values() for m, s in e.items()} for n, e in sorted(p.grids.items())}
    return {**out, "fallback": p.fallback, "plan_default": p.plan_default, "meta": dict(p.meta)}


def write_preset(path: str | os.PathLike, p: Preset) -> Path:
    """Write ``p`` as a preset file (atomically, :mod:`ndrql.io`)."""
    return write_json(path, preset_to_dict(p), indent=2)


def builtin_path(name: str) -> Path:
    """File of a shipped preset (:data:`BUILTIN`)."""
    return Path(str(resources.files("ndrql.planning").joinpath("presets", f"{name}.json")))


def load_preset(name_or_path: str | os.PathLike | Preset | None = None) -> Preset:
    """``spec``, ``tuned``, ``general``, a preset file, or a :class:`Preset` as is; ``None`` gives ``spec``.

    A name that is neither a shipped preset nor an existing file raises :class:`PresetError`.
    """
    if isinstance(name_or_path, Preset):
        return name_or_path
    key = "spec" if name_or_path is None else os.fspath(name_or_path)
    if key in BUILTIN:
        path = builtin_path(key)
    else:
        path = Path(key)
        if not path.is_file():
            raise PresetError(f"unknown preset {brief(key)}: give {', '.join(BUILTIN)} or a preset JSON file")
    note_input(path, "the preset")
    data = load_json(read_capped(path, "preset", MAX_TEXT_BYTES, PresetError), f"preset {brief(str(path))}", PresetError)
    return preset_from_dict(data, source=str(path) if key not in BUILTIN else key)


def plan_default_preset(weights: str | os.PathLike | None = None, partial: bool = False) -> str:
    """The preset ``ndrql plan`` uses without ``--preset``: the one searched for its weights (``tuned``
    for ``paper``; ``general`` for ``general``, the default, or a weights file) when that search's
    constants won their check on fresh seeds (``plan_default``), else ``tuned`` if its did, else ``spec``.
    On a map the planner does not fully know (``partial``), ``belief`` (:data:`BELIEF_PRESET`) in place of
    ``general`` when it is installed and won its check on belief maps (``plan_default``)."""
    first = "tuned" if weights is not None and os.fspath(weights) == "paper" else "general"
    if partial and first == "general" and builtin_path(BELIEF_PRESET).is_file() and load_preset(BELIEF_PRESET).plan_default:
        return BELIEF_PRESET
    for name in dict.fromkeys((first, "tuned")):
        if builtin_path(name).is_file() and load_preset(name).plan_default:
            return name
    return "spec"


def method_configs(preset: Preset | None, method: str, ql: QLConfig = QLConfig(),
                   priors: PriorConfig = PriorConfig(), grid: int | None = None) -> tuple[QLConfig, PriorConfig]:
    """Constants of ``method``: ``ql``/``priors`` without a preset; with one, its entry for the
    method (on a grid of ``grid`` cells per side, :meth:`Preset.setting`), on which the fields of
    ``ql``/``priors`` that differ from the defaults win (the API's rule)."""
    for given, cls, name in ((ql, QLConfig, "config"), (priors, PriorConfig, "prior_config")):
        if not isinstance(given, cls):
            raise PresetError(f"{name} must be a {cls.__name__}, got {brief(given)}")
    if preset is None:
        return ql, priors
    from dataclasses import fields

    q_over = {f.name: getattr(ql, f.name) for f in fields(QLConfig) if getattr(ql, f.name) != getattr(QLConfig(), f.name)}
    p_over = {f.name: getattr(priors, f.name) for f in fields(PriorConfig)
              if getattr(priors, f.name) != getattr(PriorConfig(), f.name)}
    return preset.configs(method, q_over, p_over, grid)


def spec_preset() -> Preset:
    """The paper-reproduction constants for every method (what ``spec.json`` holds)."""
    return Preset(name="spec", meta={"description": "the paper-reproduction constants for every method"})


def configs_dict(ql: QLConfig, priors: PriorConfig) -> dict[str, dict[str, Any]]:
    """The searchable constants of a config pair, for reports."""
    return {"ql": {k: getattr(ql, k) for k in PRESET_FIELDS["ql"]},
            "priors": {k: getattr(priors, k) for k in PRESET_FIELDS["priors"]}}


__all__ = ["ANY", "BELIEF_PRESET", "BUILTIN", "READS", "nearest_grid", "FORMAT", "MethodSetting", "PRESET_FIELDS", "Preset", "PresetError", "VERSION", "builtin_path",
           "configs_dict", "load_preset", "method_configs", "plan_default_preset", "preset_from_dict", "preset_to_dict", "spec_preset",
           "write_preset"]
