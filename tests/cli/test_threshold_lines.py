"""plan's summary says why NDR-QI has no threshold when the prediction was still judged informative: the
preset's Eq. 7 schedule stops above the threshold that joins start and goal (the judge searches the paper's
schedule, down to 0)."""

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
        return ndrql.solve(two_walls(), (10, 10), (110, 150), methods=["NDR-QL"], seeds=[0], **kw)


def test_a_schedule_that_stops_early_is_said_not_contradicted():
    report = _solve(priors={"thd_tail": 0})  # the general preset's schedule at this grid stops at 0.064 without its tail
    cfg = report.request.constants("NDR-QL", max(report.grid.blocked.shape))[1]
    q = report.info["prediction_quality"]
    lines = "\n".join(summary_lines(report))
    assert threshold_schedule(cfg)[-1] > 0.05
    # with the shipped weights the region joins start and goal only at 0.02 here (pinned: new weights may move it)
    assert report.thresholds["NDR-QL"] is None and q["informative"]
    assert q["threshold"] < threshold_schedule(cfg)[-1]
    assert (f"NDR-QI threshold none (mask 0 everywhere: its schedule {schedule_text(cfg)} stops above "
            f"{q['threshold']:.2f}, the highest threshold that joins start and goal)") in lines
    assert f"prediction: informative (region threshold {q['threshold']:.2f}" in lines


def test_no_threshold_in_the_schedule_the_judge_searched_too():
    # explicit prior fields are what the judge searches as well: then nothing joins and the line says where
    report = _solve(priors={"thd_start": 0.9, "thd_step": 0.4, "thd_tail": 0}, fallback="none")
    assert report.thresholds["NDR-QL"] is None
    assert no_threshold(report, "NDR-QL") == "none (mask 0 everywhere: no threshold in [0.1, 0.9] by 0.4 joins start and goal)"
    assert "prediction: uninformative" in "\n".join(summary_lines(report))


def test_the_json_carries_the_same_reason():
    report = _solve(priors={"thd_tail": 0})
    out = report.to_dict()
    assert out["ndr_qi_threshold"]["NDR-QL"] is None
    reason = out["ndr_qi_threshold_reason"]["NDR-QL"]
    assert reason.startswith("mask 0 everywhere: its schedule ") and "stops above" in reason
    assert f"NDR-QI threshold none ({reason})" in "\n".join(summary_lines(report))
    joined = _solve(priors={"thd_start": 0.99, "thd_step": 0.01})  # the paper's schedule reaches 0.02: a threshold
    assert joined.thresholds["NDR-QL"] is not None and joined.to_dict()["ndr_qi_threshold_reason"] == {}


def test_the_shipped_schedule_goes_on_to_the_threshold_that_joins():
    # the general preset's tail (thd_tail 1): the same map gets the threshold the judge found, and the distance
    # through the region with it
    report = _solve()
    q = report.info["prediction_quality"]
    cfg = report.request.constants("NDR-QL", max(report.grid.blocked.shape))[1]
    assert cfg.thd_tail == 1 and report.thresholds["NDR-QL"] is not None
    assert report.thresholds["NDR-QL"] <= threshold_schedule(dataclasses.replace(cfg, thd_tail=0))[-1]
    assert report.to_dict()["ndr_qi_threshold_reason"] == {}
    assert report.info["qi_distance"].startswith("moves through the region")
    assert q["informative"]
