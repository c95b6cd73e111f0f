"""The prediction stage of a plan (pipeline/prior_stage.py): the request's sources under the time budget, one Eq. 7
search per plan whose threshold the priors take, IQL-BFS where every source is rejected, the trace in the JSON."""

from __future__ import annotations

import dataclasses
import json
import sys
import threading
import warnings

import numpy as np
import pytest

import ndrql
from ndrql.cli import main as cli_main
from ndrql.errors import FallbackWarning
from ndrql.pipeline import prior_stage
from ndrql.pipeline.settings import PlanSettings
from ndrql.pipeline.sources import GridPriors, SourceInput
from ndrql.planning import priors as P

from helpers import two_walls

START, GOAL = (10, 10), (110, 150)


def _quiet_solve(*args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return ndrql.solve(*args, **kw)


# --- one Eq. 7 search per plan ---------------------------------------------------------------------------------


@pytest.fixture
def searches(monkeypatch):
    """Counts calls of adaptive_threshold wherever ndrql imported it (every module holding the function)."""
    original = P.adaptive_threshold
    calls = []

    def counting(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    sites = [m for name, m in list(sys.modules.items())
             if name.startswith("ndrql") and getattr(m, "adaptive_threshold", None) is original]
    assert {"ndrql.planning.priors", "ndrql.pipeline.judge"} <= {m.__name__ for m in sites}
    for m in sites:
        monkeypatch.setattr(m, "adaptive_threshold", counting)
    return calls


@pytest.mark.parametrize("kw", [{}, {"predictions": "model"}, {"predictions": "model", "priors": {"thd_tail": 0}},
                                {"methods": ["N-Q", "NDR-QL"]}, {"predictions": "oracle"}],
                         ids=["default-policy", "model", "model-rejected", "two-ndr-methods", "oracle"])
def test_one_eq7_search_per_plan(searches, kw):
    kw = {"methods": ["NDR-QL"], **kw}
    report = _quiet_solve(two_walls(), START, GOAL, seeds=2, workers=1, **kw)
    assert len(searches) == 1, f"{len(searches)} Eq. 7 searches in one plan"
    q = report.info["prediction_quality"]
    for m, thd in report.thresholds.items():  # every NDR method took the judge's threshold
        assert thd == q["threshold"], m


def test_one_eq7_search_per_plan_from_the_cli(searches, tmp_path, capsys):
    np.save(tmp_path / "m.npy", two_walls())
    code = cli_main(["plan", str(tmp_path / "m.npy"), "--start", "10,10", "--goal", "110,150", "--seeds", "2",
                     "--workers", "1", "--json", str(tmp_path / "p.json")])
    assert code == 0, capsys.readouterr().err
    assert len(searches) == 1


# --- the time budget --------------------------------------------------------------------------------------------


RELEASE = threading.Event()


class SlowSource:
    """A bounded source that takes far longer than the test's budget (released when the test ends)."""

    name = "head"
    bounded = True
    asked = 0

    def digest(self) -> str:
        return ""

    def give(self, problem: SourceInput) -> GridPriors:
        SlowSource.asked += 1
        RELEASE.wait(60.0)
        return GridPriors(self.name, np.ones(problem.grid.blocked.shape), None, None)


@pytest.fixture
def slow_head(monkeypatch):
    RELEASE.clear()
    SlowSource.asked = 0
    monkeypatch.setitem(prior_stage.NAMED_SOURCES, "head", SlowSource)
    yield SlowSource
    RELEASE.set()


def test_a_source_past_the_budget_is_said_and_iql_bfs_plans(slow_head):
    with pytest.warns(FallbackWarning, match="NDR-QL did not run, IQL-BFS ran instead"):
        report = ndrql.solve(two_walls(), START, GOAL, "NDR-QL", 1, predictions="head", workers=1,
                             settings=PlanSettings(predict_budget=0.05))
    assert slow_head.asked == 1
    assert report.methods == ("IQL-BFS",) and report.results[0].requested_method == "NDR-QL"
    d = report.to_dict()
    assert [t["source"] for t in d["sources"]] == ["head"] and d["policy"] == ["head"]
    assert d["sources"][0]["accepted"] is False and d["sources"][0]["reason"].startswith("over the time budget (")
    assert d["prediction_quality"]["informative"] is False and d["fallback"]["ran"] == "IQL-BFS"
    assert report.results[0].converged


def test_past_the_budget_with_fallback_none_there_is_nothing_to_keep(slow_head):
    with pytest.warns(FallbackWarning, match="IQL-BFS ran instead"):
        report = ndrql.solve(two_walls(), START, GOAL, "NDR-QL", 1, predictions="head", workers=1,
                             settings=PlanSettings(predict_budget=0.05, fallback=None))
    assert report.methods == ("IQL-BFS",)
    assert "no prediction to keep with fallback none" in report.info["prediction_quality"]["reasons"]


def test_the_cli_says_which_source_ran_out_of_time(slow_head, tmp_path, capsys):
    np.save(tmp_path / "m.npy", two_walls())
    code = cli_main(["plan", str(tmp_path / "m.npy"), "--start", "10,10", "--goal", "110,150", "--prior-from", "head",
                     "--predict-budget", "0.05", "--json", str(tmp_path / "p.json")])
    out = capsys.readouterr().out
    assert code == 0
    line = [x for x in out.splitlines() if x.startswith("prediction:")]
    assert len(line) == 1 and line[0].startswith("prediction: head rejected (over the time budget (")
    assert "NDR-QL fell back to IQL-BFS (the exact BFS distance)" in line[0]
    assert json.loads((tmp_path / "p.json").read_text())["runs"][0]["method"] == "IQL-BFS"


# --- the trace ----------------------------------------------------------------------------------------------------


def test_the_json_names_every_source_tried_in_order():
    """A policy of two sources: the network, rejected here (its region joins start and goal only below the
    schedule's end), then the exact prior, accepted; the priors are the exact source's."""
    request = ndrql.build_request(two_walls(), START, GOAL, methods=["NDR-QL"], seeds=[0], predictions="model",
                                  priors={"thd_tail": 0})
    report = _quiet_solve(dataclasses.replace(request, sources=("model", "exact")), workers=1)
    d = report.to_dict()
    assert d["policy"] == ["model", "exact"] and [t["source"] for t in d["sources"]] == ["model", "exact"]
    assert [t["accepted"] for t in d["sources"]] == [False, True]
    assert d["sources"][0]["reason"].startswith("no region threshold connects start and goal")
    assert d["prediction_quality"]["source"] == "exact" and d["prediction_quality"]["informative"]
    assert report.methods == ("NDR-QL",) and "fallback" not in d
    assert report.thresholds["NDR-QL"] == pytest.approx(d["sources"][1]["threshold"], abs=1e-4)
    assert report.info["qi_distance"].endswith("the exact BFS distance elsewhere")
    from ndrql.cli.plan_report import sources_text

    assert sources_text(d["sources"]).startswith("prediction: model rejected (no region threshold")
    assert "; exact accepted (Eq. 7 threshold " in sources_text(d["sources"])


def test_cli_and_api_take_the_same_steps_with_the_default_policy(tmp_path, capsys):
    np.save(tmp_path / "m.npy", two_walls())
    code = cli_main(["plan", str(tmp_path / "m.npy"), "--start", "10,10", "--goal", "110,150", "--seeds", "2",
                     "--workers", "1", "--json", str(tmp_path / "p.json")])
    out = capsys.readouterr().out
    assert code == 0
    cli = json.loads((tmp_path / "p.json").read_text())
    api = _quiet_solve(str(tmp_path / "m.npy"), START, GOAL, seeds=2, workers=1)
    assert cli["policy"] == api.info["policy"] == ["exact"]
    assert [r["total_steps"] for r in cli["runs"]] == [r.total_steps for r in api.results]
    assert [r["path"] for r in cli["runs"]] == [[list(c) for c in r.path] for r in api.results]
    assert cli["ndr_qi_threshold"] == api.thresholds
    assert "prediction: exact accepted (Eq. 7 threshold" in out
