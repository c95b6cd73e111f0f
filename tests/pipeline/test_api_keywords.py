"""The front door states what runs: solve and plan take every request keyword explicitly (issue 53, item 5)."""

from __future__ import annotations

import dataclasses
import inspect
import warnings

import numpy as np
import pytest

import ndrql
from ndrql.api import REQUEST_KEYWORDS
from ndrql.errors import NdrqlError
from ndrql.pipeline.request import build_request
from ndrql.pipeline.settings import PlanSettings


def _keywords(fn) -> set[str]:
    ps = inspect.signature(fn).parameters.values()
    assert not any(p.kind is p.VAR_KEYWORD for p in ps), f"{fn.__name__} hides keywords behind **kwargs"
    return {p.name for p in ps}


def test_every_request_keyword_and_setting_is_a_named_parameter():
    """A keyword added to build_request or a field added to PlanSettings without its API keyword fails here."""
    wanted = (set(inspect.signature(build_request).parameters) - {"map_source", "setting_fields", "info"}) | \
        {f.name for f in dataclasses.fields(PlanSettings)}
    assert wanted == set(REQUEST_KEYWORDS)
    assert wanted <= _keywords(ndrql.solve)
    assert wanted - {"methods", "seeds"} <= _keywords(ndrql.plan)


def _wall() -> np.ndarray:
    m = np.zeros((60, 60), bool)
    m[30, :50] = True
    return m


def test_keywords_reach_the_request():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rep = ndrql.solve(_wall(), (5, 5), (55, 5), methods=("IQL", "NDR-QL"), seeds=2, predictions="model",
                          fallback=None, grid="safe", size=30, predict_budget=None)
    assert rep.methods == ("IQL", "NDR-QL") and rep.seeds == (0, 1)
    assert rep.request.sources == ("model",) and rep.settings.fallback is None and rep.settings.predict_budget is None
    assert max(rep.grid.shape) == 30
    run = ndrql.plan(_wall(), (5, 5), (55, 5), method="IQL", seed=3)
    assert run.method == "IQL" and run.seed == 3


def test_unknown_keyword_and_a_request_with_more_arguments_are_refused():
    with pytest.raises(TypeError):
        ndrql.solve(_wall(), (5, 5), (55, 5), bogus=1)  # type: ignore[call-arg]
    req = build_request(_wall(), (5, 5), (55, 5))
    with pytest.raises(NdrqlError, match="whole plan"):
        ndrql.solve(req, grid="area")
    assert ndrql.solve(req).methods == ("NDR-QL",)
