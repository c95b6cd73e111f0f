"""Revealed as it moves: priors rebuilt on the growing belief, the Q-table kept (ndrql.pipeline.sensing)."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.pipeline.sensing import SenseConfig, run_sensed, sense
from ndrql.planning.config import QLConfig
from ndrql.planning.methods import build_priors
from ndrql.planning.runner import run_plan

S, G = (2, 2), (2, 17)


def _truth() -> np.ndarray:
    """20x20 cells, a wall at column 10 from the top to row 15 (the way round is at the bottom)."""
    t = np.zeros((20, 20), dtype=bool)
    t[0:16, 10] = True
    return t


def _priors_on(b: np.ndarray, known: np.ndarray | None = None):
    return build_priors("IQL-BFS", b, S, G)


def test_sense_sees_within_the_radius_and_not_through_walls():
    seen = sense(_truth(), np.array([[5, 7]]), 4.0)
    assert seen[5, 9] and seen[5, 10]  # up to the wall and the wall itself
    assert not seen[5, 11]  # behind it
    assert seen[5, 3] and not seen[5, 2]  # the radius


def test_a_known_map_converges_as_a_plain_run_does():
    t = _truth()
    cfg = QLConfig()
    r = run_sensed(t, t, np.ones_like(t), S, G, "IQL-BFS", 7, cfg, _priors_on, SenseConfig(radius=3, every=1))
    plain = run_plan(t, S, G, "IQL-BFS", 7, cfg, priors=_priors_on(t))
    assert r.converged and r.recomputes == 0 and set(r.known_share) == {1.0}
    assert r.result.converged and plain.converged and r.result.path_length == r.path_length >= 43
    assert r.result.convergence_episode == r.episodes >= cfg.window and r.result.convergence_steps == r.steps
    # the window is kept across the one-episode calls: the last `window` rollouts gave the same path
    assert r.episodes >= cfg.window


def test_the_hidden_wall_is_revealed_and_the_priors_rebuilt():
    t = _truth()
    belief = t.copy()
    belief[0:16, 10] = False  # the planner does not know the wall
    known = np.ones_like(t)
    known[0:16, 8:13] = False
    cfg = QLConfig()
    a = run_sensed(t, belief, known, S, G, "IQL-BFS", 1, cfg, _priors_on, SenseConfig(radius=3, every=5))
    b = run_sensed(t, belief, known, S, G, "IQL-BFS", 1, cfg, _priors_on, SenseConfig(radius=3, every=5))
    assert a.converged and a.recomputes >= 1 and a.path_length >= a.astar_length == 43
    assert a.known_share[0] > known.mean() and a.known_share == sorted(a.known_share)
    assert (a.steps, a.episodes, a.recomputes) == (b.steps, b.episodes, b.recomputes)  # same seed, same run


def test_sense_config_refuses_nonsense():
    with pytest.raises(ValueError):
        SenseConfig(radius=0)
    with pytest.raises(ValueError):
        SenseConfig(radius=2, every=0)


def _wall_map() -> tuple[np.ndarray, np.ndarray]:
    o = np.zeros((40, 40), dtype=np.uint8)
    o[0:34, 20] = 1
    m = np.zeros((40, 40), dtype=np.uint8)
    m[0:30, 14:27] = 1  # the planner does not know most of the wall
    return o, m


def test_sense_through_the_api_reveals_and_records(tmp_path):
    import ndrql

    o, m = _wall_map()
    rep = ndrql.solve(o, start=(5, 5), goal=(5, 34), methods=["IQL-BFS", "IQL"], seeds=[0, 1], size=40, hide=m,
                      sense=3, sense_every=2)
    runs = rep.info["sensing"]["runs"]
    assert rep.info["sensing"]["radius_cells"] == 3.0 and rep.info["sensing"]["every"] == 2 and len(runs) == 4
    assert all(r["known_end"] > r["known_start"] for r in runs) and any(r["recomputes"] >= 1 for r in runs)
    assert all(r.converged and r.astar_length == 87 for r in rep.results)
    assert rep.request.to_dict()["sense"] == {"radius": 3.0, "every": 2, "carry": "shift", "max_chunks": 10_000,
                                              "predict_again": False}


def test_sense_errors_are_one_clear_line():
    import ndrql
    from ndrql.errors import NdrqlError

    o, m = _wall_map()
    for kw, needle in (({"sense": 3}, "give --hide MASK"), ({"sense": 0, "hide": m}, "positive number"),
                       ({"sense_every": 2, "hide": m}, "needs --sense"), ({"sense": 2, "sense_every": 0, "hide": m}, ">= 1")):
        with pytest.raises(NdrqlError, match=needle):
            ndrql.build_request(o, (5, 5), (5, 34), methods=["IQL"], **kw)


def test_sense_cli_equals_api(ndrql_exe, tmp_path):
    import json

    import ndrql
    from tests.helpers.cli import assert_one_line_error, run_cli

    o, m = _wall_map()
    np.save(tmp_path / "map.npy", o)
    np.save(tmp_path / "mask.npy", m)
    r = run_cli(ndrql_exe, "plan", tmp_path / "map.npy", "--start", "5,5", "--goal", "5,34", "--hide", tmp_path / "mask.npy",
                "--sense", "3", "--method", "IQL-BFS", "--seeds", "2", "--size", "40", "--json", tmp_path / "out.json")
    assert r.returncode == 0, r.stderr
    assert "belief (given): 23% of the free space unknown" in r.stdout and "sensing: radius 3 cells" in r.stdout
    doc = json.loads((tmp_path / "out.json").read_text())
    api = ndrql.solve(str(tmp_path / "map.npy"), start=(5, 5), goal=(5, 34), methods=["IQL-BFS"], seeds=2, size=40,
                      hide=str(tmp_path / "mask.npy"), sense=3)
    assert [x["total_steps"] for x in doc["runs"]] == [x.total_steps for x in api.results]
    assert doc["sensing"]["runs"] == api.info["sensing"]["runs"]
    assert_one_line_error(run_cli(ndrql_exe, "plan", tmp_path / "map.npy", "--start", "5,5", "--goal", "5,34",
                                  "--sense", "3", "--method", "IQL"), "give --hide MASK")


@pytest.mark.parametrize("carry", ["shift", "reset", "keep"])
def test_every_carry_converges_and_the_rebuild_changes_the_run(carry):
    t = _truth()
    belief = t.copy()
    belief[0:16, 10] = False
    known = np.ones_like(t)
    known[0:16, 8:13] = False
    r = run_sensed(t, belief, known, S, G, "IQL-BFS", 4, QLConfig(), _priors_on, SenseConfig(radius=3, every=1, carry=carry))
    assert r.converged and r.recomputes >= 1 and r.path_length >= 43
    with pytest.raises(ValueError, match="carry"):
        SenseConfig(radius=3, carry="forget")


def test_the_predicted_distance_is_floored_at_the_grown_beliefs_bfs():
    """A rebuild after sensing floors the prediction's distance at the BFS of the belief as it now stands: a wall
    the robot has seen lengthens the floor behind it; with no distance (IQL, straight-line methods) nothing to do."""
    import numpy as np

    from ndrql.maps.fields import bfs4_filled
    from ndrql.pipeline.sources import belief_floor as floored

    first = np.zeros((12, 12), dtype=bool)
    grown = first.copy()
    grown[0:11, 6] = True  # a wall the robot sensed: the way to the goal now goes round its bottom end
    goal = (0, 11)
    shortcut = bfs4_filled(first, goal)  # what the first belief allowed
    assert floored(None, grown, goal) is None
    out = floored(shortcut, grown, goal)
    np.testing.assert_array_equal(out, np.maximum(shortcut, bfs4_filled(grown, goal)))
    assert out[0, 0] > shortcut[0, 0] and out[0, 0] == bfs4_filled(grown, goal)[0, 0]


def test_a_belief_model_predicts_again_on_each_grown_belief():
    """With ``predict_again`` the NDR methods' priors come from a fresh prediction on the belief as it stands (the
    cells still unknown in the model's channel); the same belief is predicted once (every seed starts from it);
    without it the model is not asked, and IQL-BFS never asks it."""
    from ndrql.maps.grid import PlanningGrid
    from ndrql.pipeline.sensing import learn_sensed
    from ndrql.planning.config import PriorConfig
    from ndrql.planning.methods import get_method

    o, m = _wall_map()
    ends = dict(source_shape=o.shape, source_start=(5, 5), source_goal=(5, 34))
    truth = PlanningGrid(o.astype(bool), (5, 5), (5, 34), **ends)
    belief = PlanningGrid(np.where(m > 0, False, o > 0), (5, 5), (5, 34), **ends)
    asked: list[np.ndarray] = []

    def repredict(blocked, unknown):
        asked.append(unknown.copy())
        region = np.where(blocked, 0.0, 0.5)
        return region, region, None

    flat = np.full(o.shape, 0.5)
    consts = lambda name: (QLConfig(max_episodes=400), PriorConfig())  # noqa: E731
    for methods, calls in (([get_method("NDR-QL"), get_method("IQL-BFS")], "some"), ([get_method("IQL-BFS")], "none")):
        asked.clear()
        rec: dict = {}
        learn_sensed(truth, belief, m.astype(bool), methods, [0, 1], consts, flat, flat, None,
                     SenseConfig(radius=3, every=1, predict_again=True), rec, repredict)
        assert rec["sensing"]["predictions"] == len(asked)
        if calls == "none":
            assert asked == []
            continue
        assert rec["sensing"]["predict_again"] and len(asked) >= 2  # the first belief and at least one rebuild
        assert asked[0].sum() == m.astype(bool).sum()  # nothing hidden within 3 cells of the start
        assert min(u.sum() for u in asked) < asked[0].sum()  # then the rebuilds see a grown belief
        assert all(u.sum() <= asked[0].sum() for u in asked)  # which only grows
        rebuilds = sum(r["recomputes"] for r in rec["sensing"]["runs"] if r["method"] == "NDR-QL")
        assert len(asked) <= 1 + rebuilds  # both seeds start from one belief: predicted once
    asked.clear()
    rec = {}
    learn_sensed(truth, belief, m.astype(bool), [get_method("NDR-QL")], [0], consts, flat, flat, None,
                 SenseConfig(radius=3, every=1, predict_again=False), rec, repredict)
    assert asked == [] and not rec["sensing"]["predict_again"] and rec["sensing"]["predictions"] == 0


def test_plan_with_sense_keeps_the_first_prediction_unless_asked_and_cli_equals_api(ndrql_exe, tmp_path):
    import dataclasses
    import json

    import ndrql
    from tests.helpers.cli import run_cli

    o, m = _wall_map()
    np.save(tmp_path / "map.npy", o)
    np.save(tmp_path / "mask.npy", m)
    req = ndrql.build_request(str(tmp_path / "map.npy"), (5, 5), (5, 34), methods=["NDR-QL"], seeds=2, size=40,
                              hide=str(tmp_path / "mask.npy"), sense=3)
    kept = ndrql.solve(req)
    assert not kept.info["sensing"]["predict_again"] and kept.info["sensing"]["predictions"] == 0
    again = ndrql.solve(dataclasses.replace(req, sensing=dataclasses.replace(req.sensing, predict_again=True)))
    assert again.info["sensing"]["predict_again"] and again.info["sensing"]["predictions"] >= 1
    assert all(r.converged for r in kept.results + again.results)
    r = run_cli(ndrql_exe, "plan", tmp_path / "map.npy", "--start", "5,5", "--goal", "5,34", "--hide",
                tmp_path / "mask.npy", "--sense", "3", "--method", "NDR-QL", "--seeds", "2", "--size", "40", "--json",
                tmp_path / "out.json")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "out.json").read_text())
    assert [x["total_steps"] for x in doc["runs"]] == [x.total_steps for x in kept.results]
    assert doc["sensing"]["predictions"] == 0
