"""Statistics of the experiment tables: CI against scipy, the paper's improvement definition."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats as sps

from ndrql.experiments import stats
from ndrql.experiments.paper import paper_table


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ci_matches_scipy_t_interval(seed):
    x = np.random.default_rng(seed).lognormal(11, 0.6, size=10 + seed)
    s = stats.describe(list(x))
    lo, hi = sps.t.interval(0.95, len(x) - 1, loc=x.mean(), scale=sps.sem(x))
    assert s["n"] == len(x)
    assert s["mean"] == pytest.approx(x.mean())
    assert s["median"] == pytest.approx(np.median(x))
    assert s["ci95_low"] == pytest.approx(lo)
    assert s["ci95_high"] == pytest.approx(hi)


def test_known_sample_by_hand():
    # 1..5: mean 3, sd sqrt(2.5), t(0.975, 4) = 2.776445105
    s = stats.describe([1, 2, 3, 4, 5, None])
    half = 2.7764451051977987 * np.sqrt(2.5) / np.sqrt(5)
    assert s["missing"] == 1 and s["n"] == 5 and s["min"] == 1 and s["max"] == 5
    assert s["ci95_low"] == pytest.approx(3 - half) and s["ci95_high"] == pytest.approx(3 + half)


def test_degenerate_samples():
    assert stats.describe([None, None])["mean"] is None
    one = stats.describe([7])
    assert one["mean"] == 7 and one["ci95_low"] is None
    assert stats.fmt_ci(one) == "-"


def test_relative_improvement_reproduces_paper_figures():
    """The paper's 90 / 80 / 58 % come out of its own Table 3 with the pooled definition."""
    t3 = paper_table("table3")
    ql = t3["steps"]["QL"]
    assert set(t3["improvement"]) == {"NDR-QL", "O-QL", "IQL"}
    for m, expected in t3["improvement"].items():
        assert round(stats.relative_improvement(t3["steps"][m], ql), 2) == expected
    # the per-map mean gives 58% -> 50% for IQL: not the paper's definition
    assert round(stats.per_map_improvement(t3["steps"]["IQL"], ql), 2) == 0.50


def test_relative_improvement_rejects_mismatch():
    with pytest.raises(ValueError):
        stats.relative_improvement([1, 2], [1])


def test_paper_numbers_cover_every_row():
    """paper_numbers.json has a reference for every row the tables print, in the paper's shape."""
    from ndrql.experiments.table2 import TABLE2_ROWS
    from ndrql.experiments.table3 import TABLE3_METHODS
    from ndrql.experiments.table4 import TABLE4_VARIANTS

    t1, t2, t3, t4 = (paper_table(f"table{i}") for i in range(1, 5))
    assert list(t1["rows"]) == ["RGP", "NEED", "MPT", "NDR"] and all(len(v) == 4 for v in t1["rows"].values())
    assert list(t2["steps"]) == [m.name for m in TABLE2_ROWS] and all(len(v) == 5 for v in t2["steps"].values())
    assert list(t3["steps"]) == list(t3["paths"]) == list(TABLE3_METHODS)
    assert all(len(v) == 8 for v in (*t3["steps"].values(), *t3["paths"].values()))
    assert list(t4["rows"]) == [v.name for v in TABLE4_VARIANTS] and t4["rows"]["point+GD"] == t1["rows"]["NDR"]
    with pytest.raises(KeyError, match="valid: table1"):
        paper_table("table5")


@pytest.mark.parametrize("k,n", [(8, 10), (0, 10), (10, 10), (143, 172), (1, 1)])
def test_wilson_interval_matches_scipy(k, n):
    lo, hi = stats.wilson_interval(k, n)
    ref = sps.binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    assert (lo, hi) == pytest.approx((ref.low, ref.high), abs=1e-6)


def test_wilson_interval_by_hand_and_bad_input():
    assert stats.wilson_interval(8, 10) == pytest.approx((0.4902, 0.9433), abs=1e-4)  # the textbook 8 of 10
    assert all(np.isnan(stats.wilson_interval(0, 0)))
    with pytest.raises(ValueError, match="0..10"):
        stats.wilson_interval(11, 10)

