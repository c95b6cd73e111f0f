"""Each user-facing parameter of a plan is defined, defaulted and validated once.

The commands that turn a map into a grid (``plan``, ``astar``, ``map info``, ``predict``) leave every
setting of :class:`~ndrql.pipeline.settings.PlanSettings` unset unless the user gives it (or take the
default from it), so :func:`~ndrql.pipeline.request.build_request` decides it; the constants are the
tuples of :mod:`ndrql.pipeline.request`; :func:`ndrql.solve` and :func:`ndrql.plan` take the request
plus a handful of arguments.
"""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import re
from pathlib import Path

import ndrql
from ndrql.cli import build_parser
from ndrql.pipeline.request import PRIOR_FIELDS, QL_FIELDS
from ndrql.pipeline.settings import PlanSettings
from ndrql.planning.config import PriorConfig, QLConfig

SRC = Path(ndrql.__file__).parent
#: Flag dest -> PlanSettings field, where the names differ.
RENAMED = {"max_pixels": "max_map_pixels"}


def _subparser(*names: str) -> argparse.ArgumentParser:
    parser = build_parser()
    for name in names:
        action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        parser = action.choices[name]
    return parser


def test_commands_leave_plan_settings_to_the_builder():
    fields = {f.name: f.default for f in dataclasses.fields(PlanSettings)}
    for cmd in (("plan",), ("astar",), ("map", "info"), ("predict",)):
        seen = 0
        for action in _subparser(*cmd)._actions:
            name = RENAMED.get(action.dest, action.dest)
            if name in fields:
                seen += 1
                assert action.default is None or action.default == fields.get(name), (cmd, action.dest, action.default)
        assert seen >= 2, cmd


def test_plan_constants_flags_are_the_requests_fields():
    dests = {a.dest[4:]: a.default for a in _subparser("plan")._actions if a.dest.startswith("cfg_")}
    assert set(dests) == set(QL_FIELDS) | set(PRIOR_FIELDS) and set(dests.values()) == {None}
    assert set(QL_FIELDS) <= {f.name for f in dataclasses.fields(QLConfig)}
    assert set(PRIOR_FIELDS) <= {f.name for f in dataclasses.fields(PriorConfig)}


def test_solve_and_plan_name_every_keyword():
    """The request's keywords are named parameters, none hidden behind **kwargs (issue 53; the full list is checked
    against build_request and PlanSettings in test_api_keywords.py)."""
    for fn in (ndrql.solve, ndrql.plan):
        kinds = [p.kind for p in inspect.signature(fn).parameters.values()]
        assert inspect.Parameter.VAR_KEYWORD not in kinds and inspect.Parameter.VAR_POSITIONAL not in kinds, fn.__name__


def test_input_dependent_defaults_are_decided_in_one_module():
    """The fallback method and the 'map file vs dataset sample' grid rule appear in the builder only."""
    hits = {}
    pattern = re.compile(r'"area" if (sample|args\.sample)|fallback = None if sample|DEFAULT_FALLBACK =')
    for path in SRC.rglob("*.py"):
        if pattern.search(path.read_text(encoding="utf-8")):
            hits[str(path.relative_to(SRC))] = True
    assert sorted(hits) == ["pipeline/request.py"], sorted(hits)
