"""The propagating head as ``plan``'s last resort above 128 cells (:mod:`ndrql.pipeline.propagated`): asked only
where the companion, the base, the relay and four orientations all failed; its region replaces the prediction
only when it passes the same test, and the summary says what happened."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.model import propagation
from ndrql.pipeline import propagated as mod
from ndrql.pipeline.predictions import predict_on_grid, second_opinion_note
from ndrql.planning.config import PriorConfig

from tests.pipeline.test_relay import BLOCKED, GOAL, N, START, _Base, _Out, _Reach, _seen

BAND = np.zeros((N, N))
BAND[1:4, :] = 0.95  # joins start and goal, covers 2% of the free cells
HAZE = np.full((N, N), 0.6)  # joins them but covers everything


def _first() -> _Out:
    r = np.zeros((N, N))
    r[1:4, 2:12] = 0.9
    return _Out(r, r * 0.5, None, _seen(np.zeros((512, 512)), (1, 1), (2, 2), 1))


@pytest.fixture
def head(monkeypatch):
    """The shipped head replaced by one whose answer the test sets; records what it was asked."""
    asked = []

    def answer(prob):
        monkeypatch.setattr(propagation, "available", lambda: True)
        monkeypatch.setattr(propagation, "propagate", lambda b, s, g, threads=0: asked.append((s, g)) or prob.copy())
        return asked
    return answer


def test_a_head_whose_region_passes_becomes_region_and_guideline(head):
    asked = head(BAND)
    first = _first()
    out, info = mod.propagated(None, BLOCKED, START, GOAL, first, PriorConfig())
    assert asked == [(START, GOAL)] and info["served"] is True and info["reason"] is None
    assert np.array_equal(out.region, BAND) and np.array_equal(out.guideline, BAND)
    assert out.distance is first.distance and out.seen is first.seen
    assert info["iterations"] == propagation.iterations((N, N), int(propagation.read_record()["chunk"]))
    assert info["graph_sha256"] == propagation.read_record()["onnx_sha256"][:16]  # which head served, in plan's JSON
    assert mod.propagated_note(info) == f"; the propagating head ({info['iterations']} iterations) served"


def test_a_head_whose_region_fails_changes_nothing_and_says_why(head):
    head(HAZE)
    first = _first()
    out, info = mod.propagated(None, BLOCKED, START, GOAL, first, PriorConfig())
    assert out is first and info["served"] is False and "covers" in info["reason"]
    assert "did not serve either (" in mod.propagated_note(info)


def test_without_a_shipped_head_nothing_is_asked(monkeypatch):
    monkeypatch.setattr(propagation, "available", lambda: False)
    first = _first()
    out, info = mod.propagated(None, BLOCKED, START, GOAL, first, PriorConfig())
    assert out is first and info is None and mod.propagated_note(info) == ""


def test_predict_on_grid_asks_the_head_only_where_the_relay_failed(head):
    asked = head(BAND)
    region, guide, info, _ = predict_on_grid(_Base(_Reach(60)), BLOCKED, START, GOAL)  # the relay serves
    assert asked == [] and "propagated" not in info["second_opinion"]
    region, guide, info, _ = predict_on_grid(_Base(_Reach(10)), BLOCKED, START, GOAL)  # the relay fails
    assert asked == [(START, GOAL)] and info["second_opinion"]["propagated"]["served"] is True
    assert np.array_equal(region, BAND) and np.array_equal(guide, BAND)
    iters = info["second_opinion"]["propagated"]["iterations"]
    assert second_opinion_note(info).endswith(f"; the propagating head ({iters} iterations) served")


def test_the_report_line_counts_the_head():
    from ndrql.experiments.transfer_floors import second_opinion_line

    failed = {"hops": [[1, 2]], "served": False, "reason": "z"}
    records = [{"skipped": False, "second_opinion": {"asked_because": "x", "served": False, "reason": "y",
                                                     "relay": failed, "propagated": p}}
               for p in ({"iterations": 256, "served": True, "reason": None},
                         {"iterations": 256, "served": False, "reason": "z"})]
    assert second_opinion_line(records).endswith("the propagating head was asked on 2 maps and served on 1")
