"""plan's summary says why NDR-QI has no threshold, and it agrees with the prediction line: the judge searches the
NDR method's own Eq. 7 schedule (one search, whose threshold the priors take), so a schedule that stops above the
threshold that would join start and goal rejects the prediction instead of leaving the mask empty unsaid."""

from __future__ import annotations

import dataclasses
import warnings

from helpers import two_walls

import ndrql
from ndrql.cli.plan_report import no_threshold, summary_lines
from ndrql.planning.priors import schedule_text, threshold_schedule


def _solve(**kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return ndrql.solve(two_walls(), (10, 10), (110, 150), methods=["NDR-QL"], seeds=[0], predictions="model", **kw)


def test_a_schedule_that_stops_early_rejects_the_prediction_and_iql_bfs_runs():
    # the general preset's schedule at this grid stops at 0.064 without its tail; with the shipped weights the
    # region joins start and goal only at 0.03 here (pinned: new weights may move it)
    report = _solve(priors={"thd_tail": 0})
    cfg = report.request.constants("NDR-QL", max(report.grid.blocked.shape))[1]
    assert threshold_schedule(cfg)[-1] > 0.05
    q = report.info["prediction_quality"]
    assert not q["informative"] and q["threshold"] is None and q["source"] == "model"
    assert report.methods == ("IQL-BFS",) and report.info["fallback"]["ran"] == "IQL-BFS"
    lines = "\n".join(summary_lines(report))
    assert ("prediction: model rejected (no region threshold connects start and goal (Eq. 7 threshold none)); "
            "NDR-QL fell back to IQL-BFS (the exact BFS distance)") in lines


def test_kept_anyway_the_ndr_qi_line_and_the_prediction_line_agree():
    report = _solve(priors={"thd_tail": 0}, fallback="none")
    cfg = report.request.constants("NDR-QL", max(report.grid.blocked.shape))[1]
    assert report.methods == ("NDR-QL",) and report.thresholds["NDR-QL"] is None
    lines = "\n".join(summary_lines(report))
    assert (f"NDR-QI threshold none (mask 0 everywhere: no threshold in {schedule_text(cfg)} joins start and goal)"
            in lines)
    assert "the rejected priors were used anyway (--fallback none)" in lines and "stops above" not in lines


def test_no_threshold_in_the_schedule_the_judge_searched_too():
    # explicit prior fields are what the judge searches as well: then nothing joins and the line says where
    report = _solve(priors={"thd_start": 0.9, "thd_step": 0.4, "thd_tail": 0}, fallback="none")
    assert report.thresholds["NDR-QL"] is None
    assert no_threshold(report, "NDR-QL") == "none (mask 0 everywhere: no threshold in [0.1, 0.9] by 0.4 joins start and goal)"
    assert "prediction: model rejected (no region threshold connects" in "\n".join(summary_lines(report))


def test_the_json_carries_the_same_reason():
    report = _solve(priors={"thd_tail": 0}, fallback="none")
    out = report.to_dict()
    assert out["ndr_qi_threshold"]["NDR-QL"] is None
    reason = out["ndr_qi_threshold_reason"]["NDR-QL"]
    assert reason.startswith("mask 0 everywhere: no threshold in ") and reason.endswith("joins start and goal")
    assert f"NDR-QI threshold none ({reason})" in "\n".join(summary_lines(report))
    assert out["sources"][0]["source"] == "model" and out["sources"][0]["reason"] == out["prediction_quality"]["reasons"][0]
    joined = _solve(priors={"thd_start": 0.99, "thd_step": 0.01})  # the paper's schedule reaches 0.03: a threshold
    assert joined.thresholds["NDR-QL"] is not None and joined.to_dict()["ndr_qi_threshold_reason"] == {}


def test_the_shipped_schedule_goes_on_to_the_threshold_that_joins():
    # the general preset's tail (thd_tail 1): the same map gets the threshold the judge found, and the distance
    # through the region with it
    report = _solve()
    q = report.info["prediction_quality"]
    cfg = report.request.constants("NDR-QL", max(report.grid.blocked.shape))[1]
    assert cfg.thd_tail == 1 and report.thresholds["NDR-QL"] is not None
    assert report.thresholds["NDR-QL"] <= threshold_schedule(dataclasses.replace(cfg, thd_tail=0))[-1]
    assert report.thresholds["NDR-QL"] == q["threshold"]  # the judge's threshold is the one the priors took
    assert report.to_dict()["ndr_qi_threshold_reason"] == {}
    assert report.info["qi_distance"] == "moves through the region (NDR-QL), the model elsewhere"
    assert q["informative"]


def test_by_default_a_known_map_takes_the_exact_prior_and_its_threshold():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = ndrql.solve(two_walls(), (10, 10), (110, 150), methods=["NDR-QL"], seeds=[0])
    q = report.info["prediction_quality"]
    assert report.info["policy"] == ["exact"] and q["source"] == "exact" and q["informative"]
    assert report.thresholds["NDR-QL"] == q["threshold"] and report.thresholds["NDR-QL"] > 0.9
    assert report.info["qi_distance"] == "moves through the region (NDR-QL), the exact BFS distance elsewhere"
