"""Eq. 7's threshold in one pass (:func:`ndrql.planning.priors.adaptive_threshold`, the widest path) answers as the
galloping search over :func:`region_connects` did, on many random and structured regions and schedules.

The reference below is that search, kept here verbatim: from the top of the schedule in steps 1, 2, 4, ... until a
threshold connects, then halving back.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ndrql.maps import native
from ndrql.planning import priors as P
from ndrql.planning.config import PriorConfig

COARSE = dict(thd_start=0.9829514178141752, thd_step=0.09190767299106636)
SCHEDULES = (
    PriorConfig(),  # the paper's: 0.99 down by 0.01 to 0
    PriorConfig(**COARSE),
    PriorConfig(**COARSE, thd_tail=1),
    PriorConfig(thd_start=0.5, thd_step=0.2),
    PriorConfig(thd_start=0.5, thd_step=0.2, thd_tail=1),
    PriorConfig(thd_start=0.9, thd_step=0.3, thd_tail=1),  # a coarse schedule that ends on 0
    PriorConfig(thd_start=0.0),  # one threshold, 0
    PriorConfig(thd_start=1.0, thd_step=0.37),
)


def galloping_threshold(region, blocked, start, goal, cfg: PriorConfig = PriorConfig()) -> float | None:
    """The implementation before the one pass: a galloping search down the schedule over region_connects."""
    blocked = np.asarray(blocked, dtype=bool)
    region = P._check_field("region", region, blocked.shape)
    schedule = P.threshold_schedule(cfg)
    connects = lambda i: P.region_connects(region, blocked, start, goal, schedule[i])  # noqa: E731
    lo, probe, step = 0, 0, 1
    while probe < len(schedule) and not connects(probe):
        lo, probe, step = probe + 1, probe + step, 2 * step
    hi = min(probe, len(schedule))
    while lo < hi:
        mid = (lo + hi) // 2
        if connects(mid):
            hi = mid
        else:
            lo = mid + 1
    return schedule[lo] if lo < len(schedule) else None


def _region(gen: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """A random region of one of several kinds: uniform, rounded to 0.01, made of schedule entries (values equal
    to thresholds, e.g. 0.63 exactly), few levels (ties), all 0, all 1, a band along a random line."""
    kind = int(gen.integers(0, 8))
    if kind == 0:
        return gen.random(shape)
    if kind == 1:
        return np.round(gen.random(shape), 2)
    if kind == 2:
        entries = np.array(sorted({t for cfg in SCHEDULES for t in P.threshold_schedule(cfg)} | {1.0}))
        return entries[gen.integers(0, len(entries), size=shape)]
    if kind == 3:
        return gen.integers(0, 3, size=shape) * 0.315
    if kind == 4:
        return np.zeros(shape)
    if kind == 5:
        return np.ones(shape)
    rows, cols = np.indices(shape)
    a, b = gen.normal(size=2)
    band = np.exp(-np.abs(a * rows + b * cols - gen.uniform(0, sum(shape))) / gen.uniform(0.5, 4))
    return np.clip(band + gen.normal(0, 0.1, size=shape), 0, 1) if kind == 6 else band


def _case(gen: np.random.Generator):
    h, w = (int(x) for x in gen.integers(1, 26, size=2))
    blocked = gen.random((h, w)) < gen.uniform(0.0, 0.45)
    start = (int(gen.integers(0, h)), int(gen.integers(0, w)))
    goal = start if gen.random() < 0.05 else (int(gen.integers(0, h)), int(gen.integers(0, w)))
    if gen.random() < 0.7:  # mostly free ends; sometimes a blocked start or goal
        blocked[start] = blocked[goal] = False
    region = _region(gen, (h, w))
    if gen.random() < 0.15:  # start or goal outside the region
        region[start if gen.random() < 0.5 else goal] = 0.0
    return region, blocked, start, goal


@pytest.fixture(params=["c", "numba"])
def kernels(request, monkeypatch):
    if request.param == "c" and native.extension() is None:
        pytest.skip("the C extension is not built")
    monkeypatch.setenv(native.KERNELS_ENV, request.param)
    return request.param


def test_one_pass_equals_the_galloping_search_on_random_regions(kernels):
    """600 problems, each under eight schedules (the paper's, coarse with and without the tail, one entry ...)."""
    gen = np.random.default_rng(41)
    answers: dict[str, int] = {"none": 0, "top": 0, "zero": 0, "between": 0}
    for case in range(600):
        region, blocked, start, goal = _case(gen)
        for k, cfg in enumerate(SCHEDULES):
            ref = galloping_threshold(region, blocked, start, goal, cfg)
            got = P.adaptive_threshold(region, blocked, start, goal, cfg)
            assert got == ref and type(got) is type(ref), (case, k, got, ref)
            sched = P.threshold_schedule(cfg)
            answers["none" if ref is None else "top" if ref == sched[0] else "zero" if ref == 0 else "between"] += 1
    assert min(answers.values()) > 100, answers


def test_one_pass_equals_the_galloping_search_on_structured_regions(kernels):
    """Corridors whose weakest cell sits exactly on, just above and just below a threshold; blocked ends."""
    free = np.zeros((9, 30), dtype=bool)
    walls = free.copy()
    walls[4, 1:29] = True  # two lanes, joined at both ends
    for blocked in (free, walls):
        for weakest in (0.63, np.nextafter(0.63, 1), np.nextafter(0.63, 0), 0.0, 0.99, 1.0, 0.005, -0.5, np.nan):
            region = np.full(blocked.shape, 0.9)
            region[:, 15] = weakest  # every way from start to goal crosses column 15
            region[8, 15] = 0.5 if blocked is walls else weakest
            for cfg in SCHEDULES:
                for start, goal in (((0, 0), (0, 29)), ((8, 0), (0, 29)), ((0, 15), (0, 15)), ((4, 0), (4, 0))):
                    ref = galloping_threshold(region, blocked, start, goal, cfg)
                    assert P.adaptive_threshold(region, blocked, start, goal, cfg) == ref, (weakest, cfg, start)
    region = np.full((9, 30), 0.9)
    region[:, 15] = 0.63
    assert P.adaptive_threshold(region, free, (0, 0), (0, 29)) == 0.62  # 0.63 itself needs region > 0.63
    blocked_start = free.copy()
    blocked_start[0, 0] = True
    assert P.adaptive_threshold(region, blocked_start, (0, 0), (0, 29)) is None
    for cfg in SCHEDULES:
        assert galloping_threshold(region, blocked_start, (0, 0), (0, 29), cfg) is None


def test_one_pass_equals_the_galloping_search_on_larger_grids(kernels):
    """Ten 60-120 cell grids with noisy bands and obstacles, under the paper's and the coarse schedules."""
    gen = np.random.default_rng(42)
    for case in range(10):
        n = int(gen.integers(60, 121))
        blocked = gen.random((n, n)) < 0.25
        start, goal = (int(gen.integers(0, n)), 0), (int(gen.integers(0, n)), n - 1)
        blocked[start] = blocked[goal] = False
        region = _region(gen, (n, n))
        for cfg in SCHEDULES[:3]:
            assert P.adaptive_threshold(region, blocked, start, goal, cfg) == galloping_threshold(
                region, blocked, start, goal, cfg), case


def test_an_end_off_the_grid_is_refused_as_before():
    region, blocked = np.ones((4, 4)), np.zeros((4, 4), dtype=bool)
    for bad in ((4, 0), (0, 4)):
        with pytest.raises(IndexError):
            galloping_threshold(region, blocked, bad, (0, 0))
        with pytest.raises(IndexError):
            P.adaptive_threshold(region, blocked, bad, (0, 0))
        with pytest.raises(IndexError):
            P.adaptive_threshold(region, blocked, (0, 0), bad)


def test_a_mismatched_region_is_refused():
    with pytest.raises(ValueError, match="downscale it first"):
        P.adaptive_threshold(np.ones((3, 4)), np.zeros((4, 4), dtype=bool), (0, 0), (1, 1))


def test_the_schedules_under_test_differ():
    assert len({tuple(P.threshold_schedule(cfg)) for cfg in SCHEDULES}) == len(SCHEDULES)
    assert dataclasses.replace(SCHEDULES[2], thd_tail=0) == SCHEDULES[1]
