"""The transfer report's figures by hand: geometric means, clear wins/ties/losses, pooled sums with and
without the largest map, path quality, the rows' constants, and what `ndrql plan` would spend."""

from __future__ import annotations

import math

import numpy as np
import pytest


from ndrql.experiments.transfer import BFS_ROW, row_configs, tuned_ql
from ndrql.experiments.transfer_report import (ROWS, against_iql, judged_threshold, plan_steps, render_tables, summarize,
                                               uninformative)
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.pipeline.fallback import MIN_THRESHOLD
from ndrql.planning.preset import load_preset


def _row(steps: list[int], threshold: float | None = None, ratio: float = 1.1) -> dict:
    return {"steps": steps, "converged": [True] * len(steps), "ratio": [ratio] * len(steps), "threshold": threshold}


def _record(key: str, thd: float | None, ql: list[int], iql: list[int], ndr: list[int], oracle: list[int],
            family: str = "maze") -> dict:
    return {"key": key, "family": family, "n": 50, "size": 50, "skipped": False, "f1": (0.8, 0.5), "judged_threshold": thd,
            "runs": {"QL": _row(ql), "IQL": _row(iql), "NDR-QL (model)": _row(ndr, thd), "NDR-QL (oracle)": _row(oracle, 0.9)}}


def test_geomean_wins_ties_losses_pooled_and_plan_by_hand():
    good = _record("a", 0.61, ql=[1000, 1000], iql=[400, 400], ndr=[100, 100], oracle=[80, 80])
    lost = _record("b", None, ql=[2000, 2000], iql=[600, 600], ndr=[3000, 3000], oracle=[100, 100])
    low = _record("c", 0.41, ql=[1000, 1000], iql=[300, 300], ndr=[200, 200], oracle=[100, 100])
    s = summarize([good, lost, low, {"key": "d", "family": "maze", "n": 50, "skipped": True}])
    assert s["maps"] == 3 and s["skipped"] == 1
    d = s["rows"]["NDR-QL (model)"]
    # per-map ratios to IQL's mean: 100/400, 3000/600, 200/300 -> geometric mean (0.25 * 5 * 2/3) ** (1/3)
    assert d["vs_iql"]["ratio"] == pytest.approx((0.25 * 5 * (2 / 3)) ** (1 / 3))
    assert d["vs_iql"]["low"] <= d["vs_iql"]["ratio"] <= d["vs_iql"]["high"]
    assert d["vs_ql"]["ratio"] == pytest.approx((0.1 * 1.5 * 0.2) ** (1 / 3))
    # no spread over seeds on either side where the seeds agree: any gap over 0.5% is clear
    assert (d["against_iql"]["wins"], d["against_iql"]["ties"], d["against_iql"]["losses"]) == (2, 0, 1)
    # pooled: (200 + 6000 + 400) / (800 + 1200 + 600); the largest map (b: 6000 + 1200) left out: 600 / 1400
    assert d["pooled_vs_iql"]["ratio"] == pytest.approx(6600 / 2600)
    assert d["pooled_vs_iql"]["without_largest"] == pytest.approx(600 / 1400) and d["pooled_vs_iql"]["largest"] == 1
    # plan: the model's run where its region joins start and goal at some Eq. 7 threshold (plan's rule:
    # MIN_THRESHOLD is 0), else IQL's: 100, 600 (IQL: no threshold joins them), 200 (threshold 0.41)
    assert MIN_THRESHOLD == 0.0
    assert s["plan_vs_iql"]["ratio"] == pytest.approx((0.25 * 1 * (2 / 3)) ** (1 / 3)) and s["plan_worse_than_iql"] == 0.0
    assert s["share"] == pytest.approx((1 - 6600 / 8000) / (1 - 560 / 8000))
    assert d["path"] == {"mean": pytest.approx(1.1), "p95": pytest.approx(1.1), "worst": pytest.approx(1.1), "not_converged": 0}


def test_a_difference_the_seeds_do_not_support_is_a_tie():
    # 10% fewer steps in the mean but the seeds scatter widely: Welch's test cannot tell them apart
    noisy = _record("a", 0.9, ql=[9000] * 4, iql=[500, 1500, 800, 1200], ndr=[400, 1400, 700, 1100], oracle=[300] * 4)
    # the same 10% with little scatter is a clear win
    steady = _record("b", 0.9, ql=[9000] * 4, iql=[1000, 1010, 990, 1000], ndr=[900, 905, 895, 900], oracle=[300] * 4)
    # within 0.5% it is a tie whatever the seeds say
    close = _record("c", 0.9, ql=[9000] * 4, iql=[1043] * 4, ndr=[1048] * 4, oracle=[1041] * 4)
    o = summarize([noisy, steady, close])["rows"]["NDR-QL (model)"]["against_iql"]
    assert (o["wins"], o["ties"], o["losses"]) == (1, 2, 0)
    lo, hi = o["win_ci"]
    assert o["win_share"] == pytest.approx(1 / 3) and lo == pytest.approx(0.0615, abs=1e-4) and hi == pytest.approx(0.7923, abs=1e-4)


def test_welch_by_hand():
    from ndrql.experiments.stats import compare_seeds

    # log steps: a = log(100) + {-d, +d}, b = log(200) + {-d, +d}: each sample variance 2 d^2, over 2 runs d^2;
    # se = sqrt(2) d, t = -log 2 / (sqrt(2) d), Welch's df = (2 d^2)^2 / (d^4 + d^4) = 2
    d = 0.05
    a = [100 * math.exp(-d), 100 * math.exp(d)]
    b = [200 * math.exp(-d), 200 * math.exp(d)]
    t = -math.log(2) / (math.sqrt(2) * d)
    from scipy import stats as sps

    assert 2 * sps.t.sf(abs(t), 2.0) < 0.05 and compare_seeds(a, b) == -1
    wide = [100 * math.exp(-0.4), 100 * math.exp(0.4)], [200 * math.exp(-0.4), 200 * math.exp(0.4)]
    assert 2 * sps.t.sf(math.log(2) / (math.sqrt(2) * 0.4), 2.0) > 0.05 and compare_seeds(*wide) == 0
    assert compare_seeds(b, a) == 1 and compare_seeds(a, a) == 0


def test_against_iql_counts_won_tied_and_clearly_lost_maps():
    iql = [1043.0, 1048.0, 1043.0, 2000.0, 1000.0]
    ndr = [1048.0, 1043.0, 1049.0, 1000.0, 1000.0]  # +0.48% (tie), -0.48% (won, tie), +0.58% (lost), won, equal
    assert against_iql(ndr, iql) == (2, 3, 1)
    assert against_iql(ndr, iql, tie=0.0) == (2, 1, 2)


def test_every_row_runs_and_the_tables_show_every_method(tmp_path):
    recs = []
    for i, fam in enumerate(["maze", "rooms"]):
        r = _record(f"{fam}-{i}", 0.9, ql=[1000, 1100], iql=[400, 420], ndr=[200, 210], oracle=[150, 150], family=fam)
        r["runs"]["QL (tuned)"] = _row([700, 720])
        r["runs"][BFS_ROW] = _row([120, 120], ratio=1.0)
        recs.append(r)
    recs.append({"key": "office-9", "family": "office", "n": 50, "skipped": True})
    text = render_tables(recs, (50,))
    for row in ROWS:
        assert f"| {row} |" in text
    assert "| office | 0 | 1 |" in text  # a family that connected nowhere: counted, not hidden
    assert "2 maps planned, 1 connect on no size tried" in text
    assert "| IQL (BFS distance) | 120 | -71% (-71..-71) |" in text  # 120 / 410 on both maps
    assert "| maze | 1 (0) | 0 | -50% (-50..-50) | 1 / 0 / 0 (100%, 21-100) | -50% (-50..-50); - |" in text
    assert "1.000, 1.000, 1.000" in text


def test_row_configs_give_each_row_its_constants():
    spec = row_configs(None)
    assert set(spec) == set(ROWS)
    assert all(c == (QLConfig(), PriorConfig()) for row, c in spec.items() if row != "QL (tuned)")
    assert spec["QL (tuned)"] == load_preset("tuned").configs("QL") != spec["QL"]
    general = load_preset("general")
    rows = row_configs(general, grid=100)
    assert rows["QL"] == (QLConfig(), PriorConfig())  # the paper's QL whatever the preset
    assert rows["QL (tuned)"] == general.configs("QL", grid=100) == tuned_ql(128)
    assert rows["IQL"] == rows[BFS_ROW] == general.configs("IQL", grid=100)
    assert rows["NDR-QL (oracle)"] == rows["NDR-QL (model)"] == general.configs("NDR-QL", grid=100)
    assert tuned_ql(64) == tuned_ql(50) == load_preset("tuned").configs("QL")


def test_plan_steps_judge_the_prediction_by_the_papers_threshold_schedule():
    rec = {"runs": {"NDR-QL (model)": {"steps": [100], "threshold": 0.48}, "IQL": {"steps": [300]}}}
    # an old record: the run's own threshold; plan keeps the model wherever some threshold joins start and goal
    assert judged_threshold(rec) == 0.48 and plan_steps(rec) == [100] and plan_steps(rec, cut=0.5) == [300]
    rec["judged_threshold"] = 0.50
    assert judged_threshold(rec) == 0.50 and plan_steps(rec) == [100] and plan_steps(rec, cut=0.5) == [100]
    assert plan_steps(rec, cut=0.6) == [300] and plan_steps({**rec, "judged_threshold": None}) == [300]


def test_above_128_cells_plan_calls_a_low_threshold_uninformative():
    from ndrql.pipeline.fallback import LARGE_GRID, LARGE_MIN_THRESHOLD

    low = LARGE_MIN_THRESHOLD / 2
    rec = {"n": 100, "size": 100, "judged_threshold": low,
           "runs": {"NDR-QL (model)": {"steps": [900], "threshold": low}, "IQL": {"steps": [300]}}}
    assert plan_steps(rec) == [900] and not uninformative(rec)  # up to 128 cells any threshold keeps the model
    grown = {**rec, "size": LARGE_GRID + 32}  # asked at 100 cells, planned on a larger grid of the ladder
    assert plan_steps(grown) == [300] and uninformative(grown)
    big = {**rec, "n": 256, "size": 256, "judged_threshold": LARGE_MIN_THRESHOLD}
    assert plan_steps(big) == [900] and not uninformative(big)  # at the cut: informative
    assert uninformative({**big, "judged_threshold": None})


def test_above_128_cells_a_region_over_most_of_the_free_cells_is_uninformative():
    from ndrql.pipeline.fallback import MAX_REGION_COVER

    rec = {"n": 256, "size": 512, "judged_threshold": 0.81, "region_cover": 0.93,
           "runs": {"NDR-QL (model)": {"steps": [5700], "threshold": 0.81}, "IQL": {"steps": [1000]}}}
    assert uninformative(rec) and plan_steps(rec) == [1000]  # a high threshold, but the region is everywhere
    assert not uninformative({**rec, "region_cover": MAX_REGION_COVER})  # at the limit: informative
    assert not uninformative({k: v for k, v in rec.items() if k != "region_cover"})  # old records: not tested
    assert not uninformative({**rec, "n": 100, "size": 100})  # up to 128 cells the cover is not limited


def test_the_bootstrap_is_seeded():
    from ndrql.experiments.stats import geomean_ratio, pooled_ratio

    rng = np.random.default_rng(3)
    a, b = rng.lognormal(6, 1, 40), rng.lognormal(6.3, 1, 40)
    assert geomean_ratio(a, b, seed=1) == geomean_ratio(a, b, seed=1) != geomean_ratio(a, b, seed=2)
    assert pooled_ratio(a, b, seed=1) == pooled_ratio(a, b, seed=1)


def test_a_run_without_a_threshold_is_recorded_not_warned(recwarn):
    from ndrql.experiments.transfer import _runs

    blocked = np.zeros((8, 8), bool)
    region = np.zeros((8, 8))  # joins start and goal at no threshold: NDR-QI's mask is 0 everywhere
    priors = {"NDR-QL (model)": (region, region.copy())}
    out = _runs(blocked, (0, 0), (7, 7), priors, [0], {"NDR-QL (model)": (QLConfig(max_episodes=50), PriorConfig())})
    assert out["NDR-QL (model)"]["threshold"] is None
    assert len(out["NDR-QL (model)"]["steps"]) == 1
    assert not [w for w in recwarn if "NDR-QI" in str(w.message)]
