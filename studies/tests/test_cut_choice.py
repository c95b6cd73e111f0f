"""studies/large_view/cut_choice.py, cut_transfer.py and route_probe.py: the cut rule of
large_view/history.md#low-thresholds-on-large-grids
on hand-made records, and the cut reaching plan's verdict."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parents[1] / "large_view"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, HERE / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def rule():
    return _load("cut_choice")


def _record(family: str, thd: float | None, iql: float, ndr: float, cover: float = 0.1) -> dict:
    return {"family": family, "size": 256, "judged_threshold": thd, "region_cover": cover,
            "runs": {"IQL": {"steps": [iql, iql]}, "NDR-QL (model)": {"steps": [ndr, ndr]}}}


def test_judge_counts_maps_under_the_cut_at_iqls_steps(rule):
    recs = [_record("maze", 0.5, 100, 25), _record("maze", 0.05, 100, 400), _record("city", 0.0, 100, 50)]
    high = rule.judge(recs, 0.1)  # the last two go to IQL: ratios 0.25, 1, 1
    assert high["uninformative"] == 2 and high["plan"] == pytest.approx(0.25 ** (1 / 3))
    assert high["slower"] == {}
    low = rule.judge(recs, 0.0)  # every map keeps the model: 0.25, 4, 0.5; maze's geomean is 1.0 -> not slower
    assert low["uninformative"] == 0 and low["plan"] == pytest.approx(math.exp(math.log(0.5) / 3))
    assert low["per_family"]["maze"] == pytest.approx(1.0) and low["slower"] == {}
    # the cover test still applies above 128 cells whatever the cut
    assert rule.judge([_record("floor", 0.3, 100, 10, cover=0.8)], 0.0)["uninformative"] == 1


def test_choose_takes_the_highest_cut_within_two_percent_and_skips_slower_families(rule):
    res = [{"cut": 0.1, "plan": 0.200, "slower": {}}, {"cut": 0.05, "plan": 0.197, "slower": {}},
           {"cut": 0.0, "plan": 0.150, "slower": {"maze": 1.2}}]
    assert rule.choose(res)["cut"] == 0.1  # 0.0 is fastest but a family is slower; 0.1 within 2% of 0.05
    res[0]["plan"] = 0.25
    assert rule.choose(res)["cut"] == 0.05
    assert rule.choose([{"cut": 0.1, "plan": 0.2, "slower": {"city": 1.1}}]) is None


def test_cut_transfer_sets_plans_cut_and_refuses_out_of_range():
    from ndrql.pipeline import fallback

    mod = _load("cut_transfer")
    shipped = fallback.LARGE_MIN_THRESHOLD
    with pytest.raises(SystemExit):
        mod.main(["--cut", "1.5", "--", "--help"])
    assert fallback.LARGE_MIN_THRESHOLD == shipped
    try:
        with pytest.raises(SystemExit):  # transfer's own --help exits after the cut is set
            mod.main(["--cut", "0.02", "--", "--help"])
        assert fallback.min_threshold(256) == 0.02 and fallback.min_threshold(128) == fallback.MIN_THRESHOLD
    finally:
        fallback.LARGE_MIN_THRESHOLD = shipped


def test_route_probe_buckets_count_maps_and_uninformative_ones():
    probe = _load("route_probe")
    rows = [{"detour": 1.05, "uninformative": False}, {"detour": 1.0, "uninformative": True},
            {"detour": 2.5, "uninformative": True}, {"detour": 1.2, "uninformative": False}]
    assert probe.buckets(rows, "detour", (1.0, 1.1, 2.0, 10**6)) == [("1-1.1", 2, 1), ("1.1-2", 1, 0), ("2 or more", 1, 1)]
