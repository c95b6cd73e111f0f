"""The second opinion (:func:`ndrql.pipeline.predictions.predict_on_grid`): on a grid the base model's view merges,
the companion predicts; when its region cannot guide planning (the test ``plan`` falls back on), the base model
predicts the grid through its own view and serves when its region can. Checked with stand-in models whose regions
are known, so each branch is decided by the region test alone."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from ndrql.pipeline.fallback import region_verdict
from ndrql.pipeline.predictions import predict_on_grid, second_opinion_note
from ndrql.planning.config import PriorConfig

N = 160  # above fallback.LARGE_GRID: the cut 0.1 and the cover test apply
START, GOAL = (2, 2), (2, N - 3)


def _corridor() -> np.ndarray:
    """A region of 0.9 along the straight row from start to goal (3 rows wide), 0 elsewhere: informative."""
    r = np.zeros((N, N))
    r[1:4, :] = 0.9
    return r


def _broken() -> np.ndarray:
    """The corridor cut in the middle: no threshold joins start and goal."""
    r = _corridor()
    r[:, N // 2] = 0.0
    return r


def _faint() -> np.ndarray:
    """The corridor at 0.05: it joins start and goal only below the large-grid cut of 0.1."""
    return _corridor() * (0.05 / 0.9)


@dataclass
class _Seen:
    image: np.ndarray
    start: tuple[int, int]
    goal: tuple[int, int]
    factor: int


@dataclass
class _Out:
    region: np.ndarray
    guideline: np.ndarray
    distance: None
    seen: _Seen


class _Model:
    """A stand-in grid-mode model: ``region`` is its prediction; a base has a ``companion`` serving every grid."""

    view = "coarse:128"
    graph_file = None
    input_mode = "grid"

    def __init__(self, name: str, region: np.ndarray, companion: "_Model | None" = None, side: int = 512,
                 factor: int = 1):
        self.weights_file = Path(name)
        self.merged_weights = None if companion is None else companion.weights_file
        self.companion, self.region, self.side, self.factor = companion, region, side, factor
        self.calls: list[str] = []

    def serving(self, n: int) -> "_Model":
        return self.companion if self.companion is not None else self

    def predict_view(self, blocked, start, goal, companion: bool = True) -> _Out:
        if companion and self.companion is not None:
            return self.companion.predict_view(blocked, start, goal)
        self.calls.append("own")
        return _Out(self.region, self.region * 0.5, None, _Seen(np.zeros((self.side, self.side)), (1, 1), (2, 2), self.factor))


def _base(companion_region: np.ndarray, base_region: np.ndarray) -> _Model:
    comp = _Model("comp.pt", companion_region)
    return _Model("base.pt", base_region, companion=comp, side=640, factor=2)


BLOCKED = np.zeros((N, N), bool)


def test_the_stand_in_regions_are_what_their_names_say():
    cfg = PriorConfig()
    assert region_verdict(_corridor(), BLOCKED, START, GOAL, cfg)[2] is None
    assert "no region threshold" in region_verdict(_broken(), BLOCKED, START, GOAL, cfg)[2]
    thd, _, why = region_verdict(_faint(), BLOCKED, START, GOAL, cfg)
    assert thd == pytest.approx(0.04) and ">= 0.1" in why


def test_an_informative_companion_is_used_and_the_base_is_never_asked():
    base = _base(_corridor(), _corridor())
    region, guide, info, _ = predict_on_grid(base, BLOCKED, START, GOAL)
    assert np.array_equal(region, _corridor()) and info["companion"] is True
    assert info["weights_file"] == "comp.pt" and "second_opinion" not in info
    assert base.calls == [] and second_opinion_note(info) == ""


@pytest.mark.parametrize("companion_region", [_broken(), _faint()], ids=["broken", "below-the-cut"])
def test_an_uninformative_companion_asks_the_base_which_serves_when_informative(companion_region):
    base = _base(companion_region, _corridor())
    region, guide, info, _ = predict_on_grid(base, BLOCKED, START, GOAL)
    assert base.calls == ["own"]
    assert np.array_equal(region, _corridor()) and np.array_equal(guide, _corridor() * 0.5)
    assert info["companion"] is False and info["weights_file"] == "base.pt"
    assert info["side"] == 640 and info["merged"] == 2  # what the base saw, not the companion
    so = info["second_opinion"]
    assert so["served"] is True and so["reason"] is None and "no region threshold" in so["asked_because"]
    assert "the base model's served" in second_opinion_note(info)


def test_when_both_are_uninformative_the_companion_stays_and_both_reasons_are_kept(monkeypatch):
    from ndrql.model import propagation

    monkeypatch.setattr(propagation, "available", lambda: False)  # the last resort, tests/pipeline/test_propagated.py
    base = _base(_broken(), _faint())
    region, _, info, _ = predict_on_grid(base, BLOCKED, START, GOAL)
    assert base.calls == ["own"] and np.array_equal(region, _broken())
    assert info["companion"] is True and info["weights_file"] == "comp.pt"
    so = info["second_opinion"]
    assert so["served"] is False and "threshold none" in so["asked_because"]
    assert "threshold 0.04" in so["reason"]
    assert "uninformative as well" in second_opinion_note(info)


def test_the_judgment_uses_the_constants_given():
    """A threshold schedule that stops above the faint corridor's 0.05 sees no connection at all: the
    verdict follows ``cfg`` (plan passes the request's quality constants)."""
    base = _base(_faint(), _corridor())
    coarse = PriorConfig(thd_start=0.9, thd_step=0.3)  # 0.9, 0.6, 0.3, 0.0
    _, _, info, _ = predict_on_grid(base, BLOCKED, START, GOAL, coarse)
    assert "threshold 0.00" in info["second_opinion"]["asked_because"]


def test_a_model_without_a_companion_is_never_second_guessed():
    alone = _Model("alone.pt", _broken())
    region, _, info, _ = predict_on_grid(alone, BLOCKED, START, GOAL)
    assert np.array_equal(region, _broken()) and "second_opinion" not in info and "companion" not in info
    assert alone.calls == ["own"]


class _Merging:
    """A view that merges every grid (what ``coarse:128`` does above 128 cells)."""

    def shows_native(self, n: int) -> bool:
        return False

    def __str__(self) -> str:
        return "coarse:128"


def test_the_prediction_cache_of_tuning_and_tables_takes_the_second_opinion_too(model_weights, tmp_path):
    """``PredictionCache`` (``ndrql tune``, the tables) on a grid the view merges gives plan's prediction: the
    base's where the companion's region is uninformative; an entry made by the companion alone before the
    second opinion existed is predicted again, a current one is read back as it is."""
    from ndrql.maps.problem import MapProblem
    from ndrql.pipeline.samples import PredictionCache, Problem
    from ndrql.io import save_npz

    p = Problem("hand", 0, "", MapProblem(np.kron(BLOCKED, np.ones((2, 2), bool)), (5, 5), (5, 2 * N - 5)),
                BLOCKED, START, GOAL, 0)
    cache = PredictionCache(tmp_path / "c", model_weights)
    base = _base(_broken(), _corridor())
    base.view = _Merging()
    cache._predictor = base
    got = cache.attach(p)
    assert np.allclose(got.region, _corridor(), atol=1e-3) and base.calls == ["own"]
    assert cache.computed == 1
    # an entry of the companion alone (no rule recorded), as the cache wrote them before: predicted again
    with np.load(cache.path(p)) as d:
        old = {k: d[k] for k in d.files if k != "rule"}
    save_npz(cache.path(p), **{**old, "region": _broken().astype(np.float16)})
    again = PredictionCache(tmp_path / "c", model_weights)
    again._predictor = base
    assert np.allclose(again.attach(p).region, _corridor(), atol=1e-3) and again.computed == 1
    third = PredictionCache(tmp_path / "c", model_weights)
    third._predictor = None  # a current entry is read without loading any model
    assert np.allclose(third.attach(p).region, _corridor(), atol=1e-3) and third.computed == 0
