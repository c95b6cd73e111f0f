"""The transfer report's pooled figures by hand: shares, and what `ndrql plan` would spend with its fallback."""

from __future__ import annotations

import pytest

from ndrql.experiments.transfer import against_iql, plan_steps, render_tables, row_configs, summarize
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.preset import load_preset


def _record(key: str, thd: float | None, ql: list[int], iql: list[int], ndr: list[int], oracle: list[int]) -> dict:
    def row(steps: list[int], threshold: float | None = None) -> dict:
        return {"steps": steps, "converged": [True] * len(steps), "ratio": [1.1] * len(steps), "threshold": threshold}

    return {"key": key, "family": "maze", "n": 50, "size": 50, "skipped": False, "f1": (0.8, 0.5),
            "runs": {"QL": row(ql), "IQL": row(iql), "NDR-QL (model)": row(ndr, thd), "NDR-QL (oracle)": row(oracle, 0.9)}}


def test_plan_falls_back_to_iql_below_the_threshold_and_the_pooled_figures_match_hand_computation():
    good = _record("a", 0.61, ql=[1000, 1000], iql=[400, 400], ndr=[100, 100], oracle=[80, 80])
    lost = _record("b", None, ql=[2000, 2000], iql=[500, 700], ndr=[3000, 3000], oracle=[100, 100])
    low = _record("c", 0.41, ql=[1000, 1000], iql=[300, 300], ndr=[200, 200], oracle=[100, 100])
    assert plan_steps(good) == [100, 100] and plan_steps(lost) == [500, 700] and plan_steps(low) == [300, 300]
    s = summarize([good, lost, low, {"key": "d", "family": "maze", "n": 50, "skipped": True}])
    ql, iql, plan = 8000, 2600, 200 + 1200 + 600
    assert s["maps"] == 3 and s["skipped"] == 1
    assert s["plan_vs_ql"] == pytest.approx(plan / ql - 1) and s["plan_vs_iql"] == pytest.approx(plan / iql - 1)
    assert s["plan_worse_than_iql"] == 0.0  # the fallback ties IQL, the model's run beats it
    assert s["vs_iql"] == pytest.approx((200 + 6000 + 400) / iql - 1)  # the model's own runs, no fallback
    assert s["beats_iql"] == pytest.approx(2 / 3)
    assert s["oracle_beats_iql"] == 1.0  # 80 < 400, 100 < 600, 100 < 300
    text = render_tables([good, lost, low], (50,))
    # no tie, one clear loss (3000 against IQL's 600) of 3 maps
    assert s["ties_iql"] == 0.0 and s["loses_to_iql"] == pytest.approx(1 / 3)
    assert "| -75.0% | -23.1% | 0% |" in text and "*plan*" in text and "| 67% | 0% | 33% | 100% |" in text
    # the pooled row adds the 95% Wilson interval of 2 maps won of 3 (0.208-0.939, by hand)
    assert s["beats_iql_ci"] == pytest.approx([0.2077, 0.9385], abs=1e-4) and "| 67% (21-94) | 0% | 33% | 100% |" in text


def test_a_map_within_half_a_percent_of_iql_is_a_tie_whichever_side_it_falls():
    # both follow a shortest route from the first episode: 20 x 52 moves plus a few exploration moves
    above = _record("a", 0.9, ql=[9000], iql=[1043], ndr=[1048], oracle=[1041])  # +0.48%: not beaten, a tie
    below = _record("b", 0.9, ql=[9000], iql=[1048], ndr=[1043], oracle=[1041])  # -0.48%: beaten, a tie
    clear = _record("c", 0.9, ql=[9000], iql=[1043], ndr=[1049], oracle=[1041])  # +0.58%: a loss
    s = summarize([above, below, clear])
    assert s["beats_iql"] == pytest.approx(1 / 3)
    assert s["ties_iql"] == pytest.approx(2 / 3) and s["loses_to_iql"] == pytest.approx(1 / 3)


def test_against_iql_counts_won_tied_and_clearly_lost_maps():
    iql = [1043.0, 1048.0, 1043.0, 2000.0, 1000.0]
    ndr = [1048.0, 1043.0, 1049.0, 1000.0, 1000.0]  # +0.48% (tie), -0.48% (won, tie), +0.58% (lost), won, equal
    assert against_iql(ndr, iql) == (2, 3, 1)  # the exact tie counts as tied, not won
    assert against_iql(ndr, iql, tie=0.0) == (2, 1, 2)  # no tolerance: only the equal map ties


def test_row_configs_give_each_row_its_methods_constants():
    spec = row_configs(None)
    assert set(spec) == {"QL", "IQL", "NDR-QL (model)", "NDR-QL (oracle)"}
    assert all(c == (QLConfig(), PriorConfig()) for c in spec.values())
    tuned = load_preset("tuned")
    rows = row_configs(tuned)
    assert rows["QL"] == tuned.configs("QL") and rows["IQL"] == tuned.configs("IQL")
    assert rows["NDR-QL (oracle)"] == rows["NDR-QL (model)"] == tuned.configs("NDR-QL") != rows["QL"]


def test_row_configs_take_a_per_grid_presets_nearest_entry():
    """With a preset of constants per grid size, each case runs with the entry nearest to its own grid."""
    from ndrql.planning.preset import preset_from_dict

    p = preset_from_dict({"format": "ndrql-preset", "version": 2, "grids": {
        "50": {"IQL": {"ql": {"alpha": 0.11}}, "NDR-QL": {"ql": {"alpha": 0.12}}},
        "100": {"IQL": {"ql": {"alpha": 0.21}}, "NDR-QL": {"ql": {"alpha": 0.22}}}}}, "g.json")
    at = {n: {row: c[0].alpha for row, c in row_configs(p, grid=n).items()} for n in (50, 64, 80, 128)}
    assert at[50] == at[64] == {"QL": 0.1, "IQL": 0.11, "NDR-QL (model)": 0.12, "NDR-QL (oracle)": 0.12}
    assert at[80] == at[128] == {"QL": 0.1, "IQL": 0.21, "NDR-QL (model)": 0.22, "NDR-QL (oracle)": 0.22}


def test_plan_steps_judge_the_prediction_by_the_papers_threshold_schedule():
    """plan judges a prediction with the paper's schedule (0.99, 0.98, ...) whatever threshold schedule the
    preset's NDR-QL runs use: a run that stepped from 0.52 to 0.48 is still informative when the fine
    schedule finds 0.50."""
    from ndrql.experiments.transfer import judged_threshold

    rec = {"runs": {"NDR-QL (model)": {"steps": [100], "threshold": 0.48}, "IQL": {"steps": [300]}}}
    assert judged_threshold(rec) == 0.48 and plan_steps(rec) == [300]  # an old record: the run's own threshold
    rec["judged_threshold"] = 0.50
    assert judged_threshold(rec) == 0.50 and plan_steps(rec) == [100]
    assert plan_steps(rec, cut=0.6) == [300] and plan_steps({**rec, "judged_threshold": None}) == [300]
