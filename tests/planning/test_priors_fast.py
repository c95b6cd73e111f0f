"""The priors' faster forms give the earlier forms' answers bit for bit (large grids: issue 53, "bounded time").

The references below are the implementations before the change, kept here verbatim: the transition table built
from flat indices, D-QI and NDR-QI gathered per ``(s, a)`` through ``divmod`` of that table, the straight line
and the tie terms on ``np.indices``, the region widened by ``scipy.ndimage.grey_dilation``. The faster forms
compute each term once per cell and gather once through the table; every output is compared as raw bits.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import ndimage

from ndrql.maps.grid import bfs_distances
from ndrql.planning import priors as P
from ndrql.planning import rules
from ndrql.planning.config import PriorConfig
from ndrql.planning.methods import build_priors, get_method, method_names

# ------------------------------------------------------------------------------------------- the references


def old_next_table(blocked: np.ndarray) -> np.ndarray:
    blocked = np.asarray(blocked, dtype=bool)
    h, w = blocked.shape
    rows, cols = np.divmod(np.arange(h * w, dtype=np.int64), w)
    nxt = np.empty((h * w, rules.N_ACTIONS), dtype=np.int32)
    for a, (dr, dc) in enumerate(rules.ACTIONS):
        r2, c2 = rows + dr, cols + dc
        inside = (r2 >= 0) & (r2 < h) & (c2 >= 0) & (c2 < w)
        target = np.where(inside, r2 * w + c2, rows * w + cols)
        ok = inside.copy()
        ok[inside] = ~blocked.ravel()[target[inside]]
        nxt[:, a] = np.where(ok, target, rows * w + cols)
    return nxt


def _old_next_cells(blocked):
    return np.divmod(old_next_table(blocked), blocked.shape[1])


def old_d_qi(blocked, goal, distance=None):
    blocked = np.asarray(blocked, dtype=bool)
    r2, c2 = _old_next_cells(blocked)
    if distance is not None:
        return np.exp(-P._check_distance(distance, blocked.shape)[r2, c2])
    return np.exp(-np.hypot(r2 - goal[0], c2 - goal[1]))


def old_widen_region(region, cells):
    region = np.asarray(region, dtype=np.float64)
    if not cells:
        return region
    four = ndimage.generate_binary_structure(2, 1)
    return ndimage.grey_dilation(region, footprint=ndimage.iterate_structure(four, int(cells)))


def old_snapped_distance(distance, goal, nearness=None, weight=0.0):
    d = np.asarray(distance, dtype=np.float64)
    rows, cols = np.indices(d.shape)
    manhattan = np.abs(rows - goal[0]) + np.abs(cols - goal[1])
    ties = P.TIE_BREAK * np.hypot(rows - goal[0], cols - goal[1])
    if nearness is not None and weight > 0:
        ties = ties + weight * (1.0 - np.asarray(nearness, dtype=np.float64))
    return manhattan + P.snap_detour(d - manhattan) + ties


def old_region_distance(blocked, region, thd, goal, distance=None):
    blocked = np.asarray(blocked, dtype=bool)
    inside = bfs_distances(blocked | ~(P._check_field("region", region, blocked.shape) > thd), goal)
    if distance is None:
        rows, cols = np.indices(blocked.shape)
        other = np.hypot(rows - goal[0], cols - goal[1])
    else:
        other = P._check_distance(distance, blocked.shape)
    return np.where(inside >= 0, inside.astype(np.float64), other)


def old_ndr_qi(blocked, start, goal, region, cfg=PriorConfig(), thd=..., mask_only=False, distance=None,
               guideline=None):
    blocked = np.asarray(blocked, dtype=bool)
    region = old_widen_region(P._check_field("region", region, blocked.shape), cfg.region_dilation)
    if thd is ...:
        thd = P.adaptive_threshold(region, blocked, start, goal, cfg)
    mask = P.region_mask(P._check_field("region", region, blocked.shape), thd, cfg).ravel()
    masked = cfg.omega_qi * mask[old_next_table(blocked)]
    if mask_only:
        return masked, thd
    r2, c2 = _old_next_cells(blocked)
    if cfg.region_distance and thd is not None:
        distance = old_region_distance(blocked, region, thd, goal, distance)
    if distance is None:
        dist = np.hypot(r2 - goal[0], c2 - goal[1])
    else:
        near = None
        if guideline is not None and cfg.guideline_ties > 0:
            near = P.route_nearness(P._check_field("guideline", guideline, blocked.shape))
        dist = old_snapped_distance(P._check_distance(distance, blocked.shape), goal, near, cfg.guideline_ties)[r2, c2]
    q0 = masked + (1.0 - cfg.omega_qi) * np.exp(-dist)
    return q0, thd


# ------------------------------------------------------------------------------------------- the problems


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _problem(gen: np.random.Generator, h: int, w: int):
    blocked = gen.random((h, w)) < gen.uniform(0.0, 0.4)
    start = (int(gen.integers(0, h)), int(gen.integers(0, w)))
    goal = (int(gen.integers(0, h)), int(gen.integers(0, w)))
    blocked[start] = blocked[goal] = False
    rows, cols = np.indices((h, w))
    band = np.exp(-np.abs((rows - start[0]) * (goal[1] - start[1]) - (cols - start[1]) * (goal[0] - start[0]))
                  / max(1.0, float(np.hypot(goal[0] - start[0], goal[1] - start[1]))) / gen.uniform(0.5, 3))
    noisy = np.clip(band + gen.normal(0, 0.15, (h, w)), 0, 1)
    region = noisy if gen.random() < 0.7 else np.round(gen.random((h, w)), 2)
    guideline = np.clip(band ** 4 + gen.normal(0, 0.05, (h, w)), 0, 1)
    exact = P.exact_distance(blocked, goal)
    distance = np.maximum(exact + gen.normal(0, 3, (h, w)), 0) if gen.random() < 0.8 else exact
    return blocked, start, goal, region, guideline, distance


SIZES = [(1, 1), (1, 7), (6, 1), (2, 2), (5, 9), (17, 13), (31, 31), (50, 50), (64, 33), (101, 97)]


@pytest.mark.parametrize("shape", SIZES)
def test_next_table_equals_the_flat_index_form(shape):
    gen = np.random.default_rng(shape[0] * 1000 + shape[1])
    for density in (0.0, 0.3, 0.7, 1.0):
        blocked = gen.random(shape) < density
        assert same_bits(rules.next_table(blocked), old_next_table(blocked))


def test_next_table_still_refuses_a_1d_grid():
    with pytest.raises(ValueError, match="2-D"):
        rules.next_table(np.zeros(4, dtype=bool))


@pytest.mark.parametrize("shape", SIZES)
def test_widen_region_equals_scipys_grey_dilation(shape):
    gen = np.random.default_rng(7 + shape[0] * 100 + shape[1])
    for values in (gen.random(shape), np.round(gen.random(shape), 1), (gen.random(shape) < 0.05) * 1.0):
        for cells in range(0, 5):
            assert same_bits(P.widen_region(values, cells), old_widen_region(values, cells)), cells


@pytest.mark.parametrize("shape", SIZES)
def test_d_qi_and_the_distances_equal_the_earlier_forms(shape):
    gen = np.random.default_rng(11 + shape[0] * 100 + shape[1])
    for _ in range(3):
        blocked, start, goal, region, guideline, distance = _problem(gen, *shape)
        assert same_bits(P.d_qi(blocked, goal), old_d_qi(blocked, goal))
        assert same_bits(P.d_qi(blocked, goal, distance), old_d_qi(blocked, goal, distance))
        near = P.route_nearness(guideline)
        for weight in (0.0, 0.3):
            assert same_bits(P.snapped_distance(distance, goal, near, weight),
                             old_snapped_distance(distance, goal, near, weight))
        for thd in (0.0, 0.5):
            for d in (None, distance):
                assert same_bits(P.region_distance(blocked, region, thd, goal, d),
                                 old_region_distance(blocked, region, thd, goal, d))


CONFIGS = (
    PriorConfig(),
    PriorConfig(thd_start=0.9829514178141752, thd_step=0.09190767299106636, region_dilation=1, guideline_ties=0.3,
                region_distance=1, thd_tail=1, omega_qi=0.41459240607471687, mask_low=-13.7311956906963),
    PriorConfig(region_dilation=2, guideline_ties=0.3, omega_qi=0.9961558112329995),
    PriorConfig(region_distance=1, omega_qi=0.8),
)


@pytest.mark.parametrize("shape", SIZES)
def test_ndr_qi_equals_the_earlier_form(shape):
    gen = np.random.default_rng(13 + shape[0] * 100 + shape[1])
    seen_none = seen_thd = 0
    for _ in range(2):
        blocked, start, goal, region, guideline, distance = _problem(gen, *shape)
        for cfg in CONFIGS:
            for kw in ({}, {"distance": distance}, {"distance": distance, "guideline": guideline},
                       {"mask_only": True}, {"thd": 0.25, "distance": distance}, {"thd": None}):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", P.ThresholdWarning)
                    got, thd = P.ndr_qi(blocked, start, goal, region, cfg, **kw)
                ref, ref_thd = old_ndr_qi(blocked, start, goal, region, cfg, **kw)
                assert thd == ref_thd and same_bits(got, ref), (cfg, kw)
                seen_none += thd is None
                seen_thd += thd is not None
    assert seen_thd > 0


def test_build_priors_of_every_method_is_unchanged_on_a_large_grid():
    """Every named method on a 150-cell grid: rewards, Q-table and threshold against the earlier forms."""
    gen = np.random.default_rng(5)
    blocked, start, goal, region, guideline, distance = _problem(gen, 150, 150)
    cfg = CONFIGS[1]
    for name in method_names():
        got = build_priors(name, blocked, start, goal, region, guideline, cfg, distance=distance)
        m = get_method(name)
        if m.n_qi:
            ref_q, ref_thd = old_ndr_qi(blocked, start, goal, region, cfg, mask_only=m.qi_mask_only,
                                        distance=distance, guideline=guideline)
        elif m.d_qi:
            exact = P.exact_distance(blocked, goal) if m.exact_distance else distance if m.model_distance else None
            ref_q, ref_thd = old_d_qi(blocked, goal, exact), None
        else:
            ref_q, ref_thd = np.zeros((blocked.size, 4)), None
        assert same_bits(got.q0, ref_q) and got.threshold == ref_thd, name
