"""Every planning method, one shared test base: convergence invariants, determinism, errors.

Synthetic NDR predictions are the A* path blurred (guideline: narrow, region: wide).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import ndimage

from ndrql.errors import NoPathError, PointError
from ndrql.maps.astar import astar4, path_is_valid
from ndrql.planning import METHODS, PlanJob, QLConfig, run_many, run_plan
from ndrql.planning.priors import exact_distance
from ndrql.planning.results import PlanResult, summarize


def blurred_path(blocked, start, goal, sigma):
    """Probabilities in [0, 1] peaking on the A* path (a stand-in for NDR outputs)."""
    mask = np.zeros(blocked.shape)
    for r, c in astar4(blocked, start, goal).path:
        mask[r, c] = 1.0
    out = ndimage.gaussian_filter(mask, sigma)
    return np.clip(out / out.max(), 0.0, 1.0)


def room_map():
    """A 20x20 map with two walls and a gap each: a detour is needed."""
    blocked = np.zeros((20, 20), dtype=bool)
    blocked[6, :15] = True
    blocked[13, 5:] = True
    blocked[2:5, 10] = True
    return blocked, (0, 0), (19, 19)


def check_result(res: PlanResult, blocked, start, goal):
    assert res.converged, res
    assert res.path is not None
    assert res.path[0] == list(start) and res.path[-1] == list(goal)
    assert path_is_valid(blocked, res.path)  # collision-free, unit moves
    assert len({tuple(c) for c in res.path}) == len(res.path)  # no revisits
    assert res.path_length == len(res.path) - 1
    assert res.astar_length == astar4(blocked, start, goal).moves
    assert res.path_length >= res.astar_length
    assert res.length_ratio == pytest.approx(res.path_length / res.astar_length)
    assert 1 <= res.first_success_episode <= res.convergence_episode == res.episodes
    assert res.convergence_steps == res.total_steps
    assert res.shortest_success_length >= res.astar_length
    assert res.shortest_success_length <= res.longest_success_length
    json.loads(res.to_json())


@pytest.fixture(scope="module")
def problem():
    blocked, start, goal = room_map()
    return dict(
        blocked=blocked,
        start=start,
        goal=goal,
        region=blurred_path(blocked, start, goal, 2.0),
        guideline=blurred_path(blocked, start, goal, 0.7),
    )


def run(problem, method, seed=0, **kw):
    if method == "IQL-NDR":  # Eq. 5 on a prior source's goal distance: here the exact one
        kw.setdefault("distance", exact_distance(problem["blocked"], problem["goal"]))
    return run_plan(problem["blocked"], problem["start"], problem["goal"], method, seed,
                    region=problem["region"], guideline=problem["guideline"], **kw)


class TestEveryMethod:
    """The shared test base: every test here runs once per method of :data:`METHODS`."""

    @pytest.fixture(params=METHODS)
    def method(self, request):
        return request.param

    def test_converges_to_a_valid_path(self, problem, method):
        res = run(problem, method, seed=0, keep_records=True)
        check_result(res, problem["blocked"], problem["start"], problem["goal"])
        rec = res.records
        assert len(rec.steps) == res.episodes
        assert (rec.greedy_length[-20:] == res.path_length).all()
        assert rec.steps.sum() == res.convergence_steps

    def test_same_seed_same_run_next_seed_differs(self, problem, method):
        a, b, c = run(problem, method, seed=5), run(problem, method, seed=5), run(problem, method, seed=6)
        assert a.same_run(b)
        assert not a.same_run(c)
        assert (a.convergence_steps, a.episodes) != (c.convergence_steps, c.episodes)

    def test_hitting_max_episodes_is_reported(self, problem, method):
        res = run(problem, method, seed=1, config=QLConfig(max_episodes=3))
        assert not res.converged
        assert res.convergence_episode is None and res.convergence_steps is None
        assert res.episodes == 3
        d = res.to_dict()
        assert d["converged"] is False and d["episodes"] == 3


def test_threshold_reported_only_with_ndr_qi():
    blocked, start, goal = room_map()
    region = blurred_path(blocked, start, goal, 2.0)
    guide = blurred_path(blocked, start, goal, 0.7)
    assert run_plan(blocked, start, goal, "IQL").threshold is None
    thd = run_plan(blocked, start, goal, "N-Q", region=region).threshold
    assert thd is not None and 0 < thd <= 0.99
    assert run_plan(blocked, start, goal, "NDR-QL", region=region, guideline=guide).threshold == thd


def test_unreachable_goal_is_a_clear_error():
    blocked = np.zeros((8, 8), dtype=bool)
    blocked[4, :] = True
    with pytest.raises(NoPathError, match="start"):
        run_plan(blocked, (0, 0), (7, 7), "QL")


@pytest.mark.parametrize("start,goal,match", [((0, 0), (9, 9), "off"), ((4, 0), (7, 7), "blocked"), ((1, 1), (1, 1), "same")])
def test_bad_points_are_clear_errors(start, goal, match):
    blocked = np.zeros((8, 8), dtype=bool)
    blocked[4, :4] = True
    with pytest.raises(PointError, match=match):
        run_plan(blocked, start, goal, "QL")


def test_parallelism_does_not_change_results():
    blocked, start, goal = room_map()
    jobs = [PlanJob(blocked, start, goal, m, s) for m in ("QL", "IQL") for s in range(4)]
    serial = run_many(jobs, workers=1)
    procs = run_many(jobs, workers=2, backend="process")
    threads = run_many(jobs, workers=2, backend="thread")
    for a, b, c, job in zip(serial, procs, threads, jobs):
        assert (a.method, a.seed) == (job.method, job.seed)
        assert a.same_run(b) and a.same_run(c)


def test_summarize():
    s = summarize([1, 2, 3, None])
    assert s["n"] == 3 and s["mean"] == 2 and s["median"] == 2
    assert s["ci95_low"] < 2 < s["ci95_high"]
    assert summarize([None])["mean"] is None


@pytest.mark.data
def test_dataset_sample_all_methods(dataset_root):
    """Real SEEN sample 0 on the 50x50 planning grid; its own labels stand in for NDR outputs."""
    from ndrql.dataset.layout import load_sample
    from ndrql.maps.grid import PlanningGrid, area_downscale

    sample = load_sample(dataset_root, "seen", 0)
    pg = PlanningGrid.from_map(sample.map, sample.start, sample.goal)
    region = area_downscale(sample.region.astype(float))
    guide = area_downscale(sample.guideline.astype(float))
    dist = exact_distance(pg.blocked, pg.goal)  # IQL-NDR's goal distance (the exact source's)
    jobs = [PlanJob(pg.blocked, pg.start, pg.goal, m, s, region=region, guideline=guide,
                    distance=dist if m == "IQL-NDR" else None) for m in METHODS for s in (0, 1)]
    results = run_many(jobs, workers=2)
    for res in results:
        check_result(res, pg.blocked, pg.start, pg.goal)
    by = {m: np.mean([r.convergence_steps for r in results if r.method == m]) for m in METHODS}
    assert by["NDR-QL"] < by["QL"]  # the paper's headline, on this sample
