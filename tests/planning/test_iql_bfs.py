"""IQL-BFS (beyond the paper): IQL with Eq. 5 on the exact BFS distance, the no-model reference of the large-grid
reports, as a method every entry point can run: hand-counted distances, its priors, its constants (IQL's unless
a preset has its own), a learned path no shorter than A*, and CLI = API."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ndrql
from ndrql.maps.grid import bfs_distances
from ndrql.planning import priors as P
from ndrql.planning.config import QLConfig
from ndrql.planning.methods import build_priors, get_method
from ndrql.planning.preset import load_preset, preset_from_dict, preset_to_dict
from ndrql.planning.runner import astar_length, run_plan

from helpers import REPO_ROOT
from helpers.cli import run_cli

SAMPLE = REPO_ROOT / "src" / "ndrql" / "data" / "sample_map.png"


def _zigzag() -> np.ndarray:
    """24 x 30 cells, two offset walls: the way from (2, 2) to (21, 27) zigzags (no straight line)."""
    g = np.zeros((24, 30), dtype=bool)
    g[8:10, :24] = True
    g[16:18, 6:] = True
    return g


def test_exact_distance_by_hand():
    # 3 x 4, a wall in column 1 except the bottom row; goal top-left; (2, 3) is 5 moves away; (0, 1) is a wall
    blocked = np.array([[0, 1, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0]], dtype=bool)
    d = P.exact_distance(blocked, (0, 0))
    assert d[0, 0] == 0 and d[2, 1] == 3 and d[0, 2] == 6 and d[2, 3] == 5 and d[0, 3] == 7
    assert d[0, 1] == 8  # blocked: the largest distance plus one
    walled = blocked.copy()
    walled[:, 2] = True  # column 3 can no longer reach the goal; the reachable cells are at most 3 moves away
    d2 = P.exact_distance(walled, (0, 0))
    assert d2[2, 1] == 3 and d2[0, 3] == d2[2, 3] == d2[1, 2] == 4


def test_priors_are_iqls_with_the_bfs_distance():
    g = _zigzag()
    goal = (21, 27)
    bfs = build_priors("IQL-BFS", g, (2, 2), goal)
    iql = build_priors("IQL", g, (2, 2), goal)
    np.testing.assert_array_equal(bfs.r_c, iql.r_c)  # Eq. 2's rewards unchanged
    np.testing.assert_allclose(bfs.q0, P.d_qi(g, goal, P.exact_distance(g, goal)))
    assert not np.allclose(bfs.q0, iql.q0) and bfs.threshold is None
    assert not get_method("IQL-BFS").needs_ndr


def test_takes_iqls_constants_unless_the_preset_has_its_own():
    general = load_preset("general")
    for n in (32, 50, 100, 128, 256, 512):
        assert general.configs("IQL-BFS", grid=n) == general.configs("IQL", grid=n)
    data = preset_to_dict(general)
    own = json.loads(json.dumps(data["grids"]["50"]["IQL"]))
    own["ql"]["alpha"] = 0.5
    data["grids"]["50"]["IQL-BFS"] = own
    p = preset_from_dict(data)
    assert p.configs("IQL-BFS", grid=50)[0].alpha == 0.5 and p.configs("IQL", grid=50)[0].alpha != 0.5


def test_learned_path_is_collision_free_and_never_shorter_than_astar():
    g = _zigzag()
    opt = astar_length(g, (2, 2), (21, 27))
    for seed in (0, 1, 2):
        r = run_plan(g, (2, 2), (21, 27), "IQL-BFS", seed, QLConfig(max_episodes=3000))
        assert r.converged and r.path_length >= opt
        path = [tuple(int(v) for v in c) for c in r.path]
        assert path[0] == (2, 2) and path[-1] == (21, 27) and not any(g[c] for c in path)
        assert all(abs(a[0] - b[0]) + abs(a[1] - b[1]) == 1 for a, b in zip(path, path[1:]))


def test_cli_and_api_give_the_same_run(tmp_path, ndrql_exe):
    out = tmp_path / "plan.json"
    r = run_cli(ndrql_exe, "plan", SAMPLE, "--start", "25,179", "--goal", "167,5", "--method", "IQL-BFS",
                "--json", out)
    assert r.returncode == 0, r.stderr[-2000:]
    cli = json.loads(out.read_text())
    assert cli["methods"] == ["IQL-BFS"] and "prediction_quality" not in cli  # no model asked
    api = ndrql.solve(str(SAMPLE), (25, 179), (167, 5), methods=["IQL-BFS"])
    run = api.results[0]
    assert run.method == "IQL-BFS" and run.converged
    assert [run.convergence_steps, run.path_length] == [cli["runs"][0]["convergence_steps"], cli["runs"][0]["path_length"]]
    assert run.path_length == cli["astar_length"]


def test_the_reports_row_runs_this_method_with_the_numbers_it_had():
    # the large-grid reports' "IQL (BFS distance)" row: before IQL-BFS existed it ran IQL with its Q-table
    # replaced by Eq. 5 on the exact distance; the method gives the same runs, and the row now runs the method
    from ndrql.experiments.transfer import BFS_ROW, _runs
    from ndrql.planning.config import PriorConfig
    from ndrql.planning.methods import Priors

    g, s, goal = _zigzag(), (2, 2), (21, 27)
    ql, pc = QLConfig(max_episodes=3000), PriorConfig()
    base = build_priors("IQL", g, s, goal, cfg=pc)
    old = Priors(r_c=base.r_c, q0=np.ascontiguousarray(P.d_qi(g, goal, P.exact_distance(g, goal))))
    before = [run_plan(g, s, goal, "IQL", seed, ql, pc, priors=old).convergence_steps for seed in (0, 1)]
    now = [run_plan(g, s, goal, "IQL-BFS", seed, ql, pc).convergence_steps for seed in (0, 1)]
    row = _runs(g, s, goal, {BFS_ROW: None}, [0, 1], {BFS_ROW: (ql, pc)})[BFS_ROW]
    assert before == now == row["steps"]


def test_an_uninformative_prediction_can_fall_back_to_it_and_says_so():
    # --fallback IQL-BFS: where the model's region joins start and goal at no threshold, the no-model reference
    # runs instead of NDR-QL, and the run and the report say so
    from ndrql.errors import FallbackWarning
    from ndrql.pipeline.settings import PlanSettings

    m = np.zeros((60, 80), dtype=bool)
    m[20:22, :60] = True
    flat = (np.zeros(m.shape), np.full(m.shape, 0.2))  # a region that joins start and goal at no threshold
    with pytest.warns(FallbackWarning, match="IQL-BFS ran instead"):
        report = ndrql.solve(m, (5, 5), (50, 10), "NDR-QL", 1, predictions=flat, workers=1,
                             settings=PlanSettings(fallback="IQL-BFS"))
    run = report.results[0]
    assert report.methods == ("IQL-BFS",) and run.requested_method == "NDR-QL" and run.fell_back
    assert report.info["fallback"]["ran"] == "IQL-BFS" and run.converged
    assert run.path_length >= report.astar_length


@st.composite
def _maps(draw):
    h, w = draw(st.integers(2, 14)), draw(st.integers(2, 14))
    rng = np.random.default_rng(draw(st.integers(0, 2**31 - 1)))
    blocked = rng.random((h, w)) < draw(st.floats(0.0, 0.45))
    goal = (int(rng.integers(h)), int(rng.integers(w)))
    blocked[goal] = False
    return blocked, goal


@settings(max_examples=200, deadline=None)
@given(_maps())
def test_exact_distance_is_a_consistent_move_count(case):
    # on random grids: 0 at the goal, never below the Manhattan distance, neighbours differ by at most one move,
    # every other reachable cell has a neighbour one move nearer, and the cells that cannot reach the goal share
    # one value above every reachable one; it equals A*'s length from any reachable cell
    blocked, goal = case
    d = P.exact_distance(blocked, goal)
    reach = bfs_distances(blocked, goal) >= 0
    h, w = blocked.shape
    assert d[goal] == 0 and reach[goal]
    rows, cols = np.indices(blocked.shape)
    assert np.all(d[reach] >= np.abs(rows - goal[0])[reach] + np.abs(cols - goal[1])[reach])
    if (~reach).any():
        assert np.unique(d[~reach]).size == 1 and d[~reach][0] == d[reach].max() + 1
    for r, c in zip(*np.nonzero(reach)):
        near = [(r + dr, c + dc) for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)) if 0 <= r + dr < h and 0 <= c + dc < w]
        near = [n for n in near if reach[n]]
        assert all(abs(d[n] - d[r, c]) <= 1 for n in near)
        if (r, c) != goal:
            assert any(d[n] == d[r, c] - 1 for n in near)
    cell = tuple(int(v) for v in np.argwhere(reach)[-1])
    assert astar_length(blocked, cell, goal) == d[cell]
