"""What ``plan --help`` says a plain run uses: the preset's constants, resolved as
:func:`~ndrql.pipeline.request.build_request` resolves them for a run without ``--preset``/``--weights``.

A plain ``ndrql plan MAP --start ... --goal ...`` runs NDR-QL with the preset searched for the default
weights (:func:`~ndrql.planning.preset.plan_default_preset`; ``general`` unless ``$NDRQL_WEIGHTS`` says
``paper``), whose constants depend on the planning grid's size (one entry per size, the nearest taken).
Each constant's flag shows those values, per grid size where they differ; a constant the preset does not
set shows the config's default, which is then what runs. tests/cli/test_plan_help.py checks the help
against a built request.
"""

from __future__ import annotations

import argparse
import os
from typing import Any

from ndrql.cli.options import add_config_flags
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.preset import PRESET_FIELDS, Preset, load_preset, plan_default_preset

#: The method a plain ``plan`` runs.
PLAIN_METHOD = "NDR-QL"


def plain_preset() -> Preset:
    """The preset a plain run uses (no ``--preset``, no ``--weights``; ``$NDRQL_WEIGHTS`` as a run reads it)."""
    return load_preset(plan_default_preset(os.environ.get("NDRQL_WEIGHTS") or None))


def number(value: Any) -> str:
    """A constant as the help prints it: 3 significant digits (integers as they are)."""
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, int):
        return str(value)
    return f"{value:.3g}"


def constant_values(preset: Preset, name: str, method: str = PLAIN_METHOD) -> list[tuple[list[int], Any]]:
    """``[(grid sizes, value), ...]``: the value of constant ``name`` for ``method`` per grid size of the
    preset (one group per run of equal values; ``[]`` sizes: the preset has no per-size entries)."""
    sizes = sorted(preset.grids) or [None]
    out: list[tuple[list[int], Any]] = []
    for n in sizes:
        s = preset.setting(method, n)
        value = getattr(s.ql, name) if hasattr(s.ql, name) else getattr(s.priors, name)
        if out and number(out[-1][1]) == number(value):
            out[-1][0].append(n)  # type: ignore[arg-type]
        else:
            out.append(([n] if n is not None else [], value))
    return out


def shown_default(preset: Preset, name: str) -> str:
    """The ``(default: ...)`` text of constant ``name``: one value, or the value per grid size."""
    groups = constant_values(preset, name)
    if len(groups) == 1:
        value = groups[0][1]
        if value is None:
            return "4 x cells"
        ours = name in PRESET_FIELDS["ql"] + PRESET_FIELDS["priors"]
        return f"{number(value)}, preset {preset.name}'s for {PLAIN_METHOD}" if ours else number(value)
    per = ", ".join(f"{number(v)} at {'/'.join(map(str, ns))}" for ns, v in groups)
    return f"preset {preset.name}'s for {PLAIN_METHOD} by grid size (nearest entry): {per} cells"


def add_constant_groups(parser: argparse.ArgumentParser, ql_fields: tuple[str, ...], prior_fields: tuple[str, ...]) -> None:
    """The advanced groups of Q-learning and prior constants, each flag with the default a plain run uses."""
    preset = plain_preset()
    note = (f"defaults: what a plain run uses, NDR-QL with preset {preset.name} (other methods, --weights paper and "
            f"--preset take that preset's own values); a flag given sets the constant for every method and grid")
    add_config_flags(parser.add_argument_group("advanced: Q-learning constants (docs/method.md)", note), QLConfig,
                     ql_fields, shown={n: shown_default(preset, n) for n in ql_fields})
    add_config_flags(parser.add_argument_group("advanced: prior constants, paper Eqs. 2-7 (docs/method.md)"),
                     PriorConfig, prior_fields, shown={n: shown_default(preset, n) for n in prior_fields})


#: ``plan --prior-from``'s help (the sources: ndrql.pipeline.sources).
PRIOR_FROM_HELP = ("where NDR-QL's priors come from (default: 'exact' on a map the planner fully knows, 'model' on a "
                   "dataset sample and with --hide): 'model' (the NDR network, --weights), 'exact' (the planning grid's "
                   "own shortest path and BFS distance), 'oracle' (drawn from the true map: the ceiling where part of it "
                   "is hidden), 'head' (the shipped propagating head), or a FILE.npz of arrays 'region' and 'guideline' "
                   "at the map's resolution, in [0, 1], as ndrql predict writes them; a source the judge rejects (Eq. 7 "
                   "joins start and goal nowhere, or only along a detour) is replaced by --fallback")
