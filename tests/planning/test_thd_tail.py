"""Eq. 7's schedule tail (``thd_tail``, beyond the paper): a coarse schedule that ends above 0 goes on by the
paper's 0.01 down to 0; the paper's schedule and every schedule that already reaches 0 are unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.planning import priors as P
from ndrql.planning.config import PriorConfig
from ndrql.planning.preset import load_preset

#: The grid-50 entry of the general preset searched this schedule: it ends at 0.0639.
COARSE = dict(thd_start=0.9829514178141752, thd_step=0.09190767299106636)


def test_the_tail_continues_a_coarse_schedule_at_the_hundredths_below_its_end():
    plain = P.threshold_schedule(PriorConfig(**COARSE))
    tail = P.threshold_schedule(PriorConfig(**COARSE, thd_tail=1))
    assert round(plain[-1], 4) == 0.0639 and tail[:len(plain)] == plain
    assert tail[len(plain):] == [0.06, 0.05, 0.04, 0.03, 0.02, 0.01, 0.0]
    assert all(a > b for a, b in zip(tail, tail[1:]))  # strictly falling: the galloping search stays valid
    assert P.schedule_text(PriorConfig(**COARSE, thd_tail=1)) == "[0.0639, 0.983] by 0.0919, then by 0.01 to 0"


def test_the_tail_changes_nothing_where_the_schedule_reaches_0():
    assert P.threshold_schedule(PriorConfig(thd_tail=1)) == P.threshold_schedule(PriorConfig())
    on_zero = PriorConfig(thd_start=0.9, thd_step=0.3, thd_tail=1)
    assert P.threshold_schedule(on_zero) == [0.9, 0.6, 0.3, 0.0]
    assert P.schedule_text(on_zero) == "[0, 0.9] by 0.3"
    # a schedule ending exactly on a hundredth does not repeat it
    assert P.threshold_schedule(PriorConfig(thd_start=0.9, thd_step=0.25, thd_tail=1))[3:] == [
        0.15, 0.14, 0.13, 0.12, 0.11, 0.1, 0.09, 0.08, 0.07, 0.06, 0.05, 0.04, 0.03, 0.02, 0.01, 0.0]


def test_a_faint_region_gets_its_threshold_with_the_tail_only():
    # a corridor whose region is 0.03 on its middle cell: the coarse schedule ends at 0.0639 and misses it
    free = np.zeros((1, 5), dtype=bool)
    region = np.array([[0.9, 0.9, 0.03, 0.9, 0.9]])
    assert P.adaptive_threshold(region, free, (0, 0), (0, 4), PriorConfig(**COARSE)) is None
    assert P.adaptive_threshold(region, free, (0, 0), (0, 4), PriorConfig(**COARSE, thd_tail=1)) == 0.02
    with pytest.warns(P.ThresholdWarning):
        _, none = P.ndr_qi(free, (0, 0), (0, 4), region, PriorConfig(**COARSE))
    _, thd = P.ndr_qi(free, (0, 0), (0, 4), region, PriorConfig(**COARSE, thd_tail=1))
    assert none is None and thd == 0.02


@pytest.mark.parametrize("seed", range(20))
def test_the_search_equals_the_walk_down_the_tailed_schedule(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(4, 20))
    blocked = rng.random((n, n)) < 0.25
    region = rng.random((n, n)) * rng.uniform(0.05, 1.0)  # faint regions reach the tail
    start, goal = (0, 0), (n - 1, n - 1)
    blocked[start] = blocked[goal] = False
    cfg = PriorConfig(**COARSE, thd_tail=1)
    walk = next((t for t in P.threshold_schedule(cfg) if P.region_connects(region, blocked, start, goal, t)), None)
    assert P.adaptive_threshold(region, blocked, start, goal, cfg) == walk


def test_thd_tail_is_0_or_1_and_a_preset_may_set_it():
    with pytest.raises(ValueError, match="thd_tail must be 0"):
        PriorConfig(thd_tail=2)
    assert PriorConfig(thd_tail=1.0).thd_tail == 1
    assert load_preset("spec").configs("NDR-QL")[1].thd_tail == 0
