"""Each prior of the paper (Eqs. 2-7) against values computed by hand on tiny maps."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from ndrql.errors import NdrqlError
from ndrql.planning import priors as P
from ndrql.planning.config import PriorConfig
from ndrql.planning.methods import METHODS, build_priors, get_method

UP, DOWN, LEFT, RIGHT = range(4)

# 3x3, centre blocked, goal bottom-right
CENTRE = np.array([[0, 0, 0], [0, 1, 0], [0, 0, 0]], dtype=bool)
GOAL = (2, 2)


def idx(r, c, w=3):
    return r * w + c


def test_d_crf_eq2():
    r = P.d_crf((3, 3), GOAL)
    assert r[2, 2] == pytest.approx(5.0)
    assert r[0, 0] == pytest.approx(5 * math.exp(-0.2 - 0.2))
    assert r[0, 2] == pytest.approx(5 * math.exp(-0.2))
    cfg = PriorConfig(r0=1.0, r_max=2.0, g_row=4.0, g_col=2.0)
    assert P.d_crf((3, 3), GOAL, cfg)[0, 1] == pytest.approx(1 + 2 * math.exp(-2 / 4 - 1 / 2))


def test_ndr_crf_eq3_and_mix_eq4():
    g = np.array([[0.0, 0.5, 1.0], [0.2, 0.0, 0.0], [0.0, 0.0, 1.0]])
    assert P.ndr_crf(g)[0, 1] == pytest.approx(2.5)
    mix = P.mixed_crf(g, GOAL)
    assert mix[0, 1] == pytest.approx(0.5 * 2.5 + 0.5 * 5 * math.exp(-0.2 - 0.1))
    assert mix[2, 2] == pytest.approx(0.5 * 5 + 0.5 * 5)
    assert P.mixed_crf(g, GOAL, PriorConfig(omega_crf=1.0))[1, 0] == pytest.approx(1.0)


def test_d_qi_eq5_uses_the_cell_the_action_leads_to():
    q = P.d_qi(CENTRE, GOAL)
    assert q.shape == (9, 4)
    assert q[idx(0, 0), DOWN] == pytest.approx(math.exp(-math.hypot(1, 2)))  # -> (1, 0)
    assert q[idx(0, 0), UP] == pytest.approx(math.exp(-math.hypot(2, 2)))  # off map: stays at (0, 0)
    assert q[idx(0, 1), DOWN] == pytest.approx(math.exp(-math.hypot(2, 1)))  # blocked: stays at (0, 1)
    assert q[idx(2, 1), RIGHT] == pytest.approx(1.0)  # -> the goal


REGION = np.array([[1.0, 0.5, 1.0], [0.8, 0.8, 0.8], [0.0, 0.0, 0.0]])
FREE = np.zeros((3, 3), dtype=bool)


def test_adaptive_threshold_picks_the_highest_that_connects():
    start, goal = (0, 0), (0, 2)
    thd = P.adaptive_threshold(REGION, FREE, start, goal)
    assert thd == pytest.approx(0.79)
    assert P.region_connects(REGION, FREE, start, goal, thd)
    assert not P.region_connects(REGION, FREE, start, goal, 0.80)
    # with the middle row blocked only the 0.5 cell connects them
    blocked = np.array([[0, 0, 0], [1, 1, 1], [0, 0, 0]], dtype=bool)
    assert P.adaptive_threshold(REGION, blocked, start, goal) == pytest.approx(0.49)


def test_adaptive_threshold_none_when_nothing_connects():
    region = REGION.copy()
    region[0, 2] = 0.0  # the goal itself is never above any threshold >= 0
    assert P.adaptive_threshold(region, FREE, (0, 0), (0, 2)) is None
    with pytest.warns(P.ThresholdWarning):
        q0, thd = P.ndr_qi(FREE, (0, 0), (0, 2), region)
    assert thd is None
    np.testing.assert_allclose(q0, 0.5 * P.d_qi(FREE, (0, 2)))  # MASK 0 everywhere


def test_ndr_qi_eq6_eq7():
    start, goal = (0, 0), (0, 2)
    q0, thd = P.ndr_qi(FREE, start, goal, REGION)
    assert thd == pytest.approx(0.79)
    dist = lambda r, c: math.exp(-math.hypot(r - goal[0], c - goal[1]))  # noqa: E731
    # (0,0) right -> (0,1): N_r 0.5 <= thd -> MASK -10
    assert q0[idx(0, 0), RIGHT] == pytest.approx(0.5 * -10 + 0.5 * dist(0, 1))
    # (0,0) down -> (1,0): N_r 0.8 > thd -> MASK 0
    assert q0[idx(0, 0), DOWN] == pytest.approx(0.5 * dist(1, 0))
    # (1,1) down -> (2,1): N_r 0 -> -10
    assert q0[idx(1, 1), DOWN] == pytest.approx(-5 + 0.5 * dist(2, 1))
    q1, _ = P.ndr_qi(FREE, start, goal, REGION, PriorConfig(omega_qi=0.25, mask_low=-4.0), thd=0.9)
    assert q1[idx(0, 0), DOWN] == pytest.approx(0.25 * -4 + 0.75 * dist(1, 0))


def test_ndr_qi_mask_term_alone_eq6():
    """Table 2's lone N-Q: Eq. 6 without its distance term, same threshold."""
    start, goal = (0, 0), (0, 2)
    q0, thd = P.ndr_qi(FREE, start, goal, REGION, mask_only=True)
    assert thd == pytest.approx(0.79)
    assert q0[idx(0, 0), RIGHT] == 0.5 * -10 and q0[idx(0, 0), DOWN] == 0.0 and q0[idx(1, 1), DOWN] == -5.0
    assert np.array_equal(q0, P.ndr_qi_mask_term(FREE, REGION, thd))
    assert not P.ndr_qi_mask_term(FREE, REGION, None).any()  # no threshold: MASK 0 everywhere


def test_ndr_qi_eq6_with_a_given_goal_distance():
    """Beyond the paper: a predicted distance, snapped to Manhattan + an even detour with straight-line
    tie-breaks, replaces the straight line in Eq. 6's distance term only."""
    start, goal = (0, 0), (0, 2)
    rows, cols = np.indices((3, 3))
    manh = np.abs(rows - goal[0]) + np.abs(cols - goal[1])
    hyp = np.hypot(rows - goal[0], cols - goal[1])
    pred = manh + np.array([[0.4, 2.9, 0.0], [0.2, 5.2, 0.1], [-3.0, 1.1, 0.0]])  # detours as a model may give them
    snapped = P.snapped_distance(pred, goal)
    detour = np.array([[0, 2, 0], [0, 6, 0], [0, 2, 0]])  # nearest even >= 0: 0.4->0, 2.9->2, 5.2->6, 1.1->2
    assert np.allclose(snapped, manh + detour + P.TIE_BREAK * hyp)
    exact = manh + np.array([[0, 0, 0], [2, 0, 0], [4, 2, 0]])  # an exact distance keeps its values (+ tie-break)
    assert np.allclose(P.snapped_distance(exact, goal), exact + P.TIE_BREAK * hyp)
    q0, thd = P.ndr_qi(FREE, start, goal, REGION, distance=pred)
    assert thd == pytest.approx(0.79)  # the threshold does not depend on the distance
    assert q0[idx(0, 0), RIGHT] == pytest.approx(0.5 * -10 + 0.5 * math.exp(-snapped[0, 1]))
    assert q0[idx(0, 0), DOWN] == pytest.approx(0.5 * math.exp(-snapped[1, 0]))
    assert q0[idx(0, 0), UP] == pytest.approx(0.5 * math.exp(-snapped[0, 0]))  # blocked move: s' = s
    # the straight line breaks the tie between two moves that Manhattan finds equally good
    q_tie, _ = P.ndr_qi(FREE, (2, 0), goal, np.ones((3, 3)), distance=manh.astype(float))
    assert q_tie[idx(1, 0), RIGHT] > q_tie[idx(1, 0), UP]  # (1,1) is nearer (0,2) in a straight line than (0,0)
    with pytest.raises(ValueError, match="distance has shape"):
        P.ndr_qi(FREE, start, goal, REGION, distance=np.zeros((2, 2)))
    with pytest.raises(ValueError, match="finite"):
        P.ndr_qi(FREE, start, goal, REGION, distance=np.full((3, 3), np.nan))
    pri = build_priors("NDR-QL", FREE, start, goal, REGION, REGION, distance=pred)
    assert np.array_equal(pri.q0, q0)
    iql = build_priors("IQL", FREE, start, goal, distance=pred)  # D-QI keeps the straight line
    assert np.array_equal(iql.q0, build_priors("IQL", FREE, start, goal).q0)


def test_prior_shape_mismatch_says_what_to_do():
    with pytest.raises(ValueError, match="downscale"):
        P.adaptive_threshold(np.zeros((5, 5)), FREE, (0, 0), (2, 2))


# --- the registry -------------------------------------------------------------------------


def test_method_table_of_spec_section_4():
    flags = {n: (m.d_crf, m.n_crf, m.d_qi, m.n_qi) for n, m in METHODS.items()}
    assert flags == {
        "QL": (False, False, False, False),
        "D-C": (True, False, False, False),
        "N-C": (False, True, False, False),
        "D-Q": (False, False, True, False),
        "N-Q": (False, False, False, True),
        "IQL": (True, False, True, False),
        "O-QL": (False, False, True, False),
        "NDR-QL": (True, True, True, True),
        "IQL-BFS": (True, False, True, False),  # beyond the paper: IQL with Eq. 5 on the exact BFS distance
        "IQL-NDR": (True, False, True, False),  # beyond the paper: IQL with Eq. 5 on the prior source's distance
    }
    assert [n for n, m in METHODS.items() if m.exact_distance] == ["IQL-BFS"]
    assert [n for n, m in METHODS.items() if m.model_distance] == ["IQL-NDR"]
    assert {n: m.constants for n, m in METHODS.items() if m.constants} == {"IQL-BFS": "IQL", "IQL-NDR": "IQL"}


def test_unknown_method_lists_valid_names():
    with pytest.raises(NdrqlError) as err:
        get_method("DQN")
    for name in METHODS:
        assert name in str(err.value)
    assert get_method("ndr-ql").name == "NDR-QL"


def test_build_priors_composes_per_method():
    g = np.array([[0.0, 0.5, 1.0], [0.2, 0.0, 0.0], [0.0, 0.0, 1.0]])
    region = np.ones((3, 3))
    start = (0, 0)
    ql = build_priors("QL", CENTRE, start, GOAL)
    assert not ql.r_c.any() and not ql.q0.any() and ql.threshold is None
    iql = build_priors("IQL", CENTRE, start, GOAL)
    np.testing.assert_allclose(iql.r_c, P.d_crf((3, 3), GOAL))
    np.testing.assert_allclose(iql.q0, P.d_qi(CENTRE, GOAL))
    np.testing.assert_array_equal(build_priors("O-QL", CENTRE, start, GOAL).q0, build_priors("D-Q", CENTRE, start, GOAL).q0)
    ndr = build_priors("NDR-QL", CENTRE, start, GOAL, region=region, guideline=g)
    np.testing.assert_allclose(ndr.r_c, P.mixed_crf(g, GOAL))
    np.testing.assert_allclose(ndr.q0, P.ndr_qi(CENTRE, start, GOAL, region)[0])
    assert ndr.threshold == pytest.approx(0.99)
    nc = build_priors("N-C", CENTRE, start, GOAL, guideline=g)
    np.testing.assert_allclose(nc.r_c, 5 * g)
    assert not nc.q0.any()


def test_ndr_methods_need_predictions():
    with pytest.raises(NdrqlError, match="--prior-from"):
        build_priors("NDR-QL", CENTRE, (0, 0), GOAL)
    with pytest.raises(NdrqlError, match="shape"):
        build_priors("N-C", CENTRE, (0, 0), GOAL, guideline=np.zeros((4, 4)))


def test_predict_hook_says_what_to_do():
    from ndrql.pipeline.predictions import predict_priors

    with pytest.raises(NdrqlError, match="missing model weights.*--prior-from"):
        predict_priors(np.zeros((201, 201), bool), (0, 0), (200, 200), weights="/nonexistent/ndr.pt")


def test_no_warning_when_the_region_connects():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        P.ndr_qi(FREE, (0, 0), (0, 2), REGION)


def _walk_down(region, blocked, start, goal, cfg):
    """Sec. 3.3 as written: every threshold from ``thd_start`` down by ``thd_step`` until one connects."""
    n = int(np.floor(cfg.thd_start / cfg.thd_step + 1e-9))
    for i in range(n + 1):
        thd = round(cfg.thd_start - i * cfg.thd_step, 9)
        if thd < 0:
            break
        if P.region_connects(region, blocked, start, goal, thd):
            return thd
    return None


@pytest.mark.parametrize("seed", range(40))
def test_adaptive_threshold_equals_the_walk_down_of_sec_3_3(seed):
    """The galloping search down the schedule gives the walk's answer, for smooth and noisy regions, walls, start
    or goal outside the region, and the paper's and coarser schedules."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(4, 24))
    blocked = rng.random((n, n)) < rng.uniform(0.0, 0.35)
    region = rng.random((n, n)) if seed % 2 else np.clip(np.cumsum(rng.normal(0, 0.2, (n, n)), axis=1) % 1.0, 0, 1)
    region = np.round(region, 2) if seed % 3 == 0 else region  # values on the schedule's own steps
    start, goal = (0, 0), (n - 1, n - 1)
    blocked[start] = blocked[goal] = False
    for cfg in (PriorConfig(), PriorConfig(thd_start=0.9333, thd_step=0.0505), PriorConfig(thd_start=0.5, thd_step=0.2)):
        assert P.adaptive_threshold(region, blocked, start, goal, cfg) == _walk_down(region, blocked, start, goal, cfg)


def test_threshold_schedule_and_its_words():
    paper = P.threshold_schedule(PriorConfig())
    assert len(paper) == 100 and paper[0] == 0.99 and paper[1] == 0.98 and paper[-1] == 0.0
    assert P.schedule_text(PriorConfig()) == "[0, 0.99]"
    coarse = PriorConfig(thd_start=0.9, thd_step=0.25)
    assert P.threshold_schedule(coarse) == [0.9, 0.65, 0.4, 0.15]  # stops above 0: 0.15 - 0.25 < 0
    assert P.schedule_text(coarse) == "[0.15, 0.9] by 0.25"


def test_the_warning_names_the_schedule_searched():
    region = REGION.copy()
    region[0, 2] = 0.0
    with pytest.warns(P.ThresholdWarning, match=r"no threshold in \[0.15, 0.9\] by 0.25 makes"):
        P.ndr_qi(FREE, (0, 0), (0, 2), region, PriorConfig(thd_start=0.9, thd_step=0.25))
