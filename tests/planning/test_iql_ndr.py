"""IQL-NDR (beyond the paper): IQL's priors (Eq. 2's D-CRF, Eq. 5's D-QI) with Eq. 5's ``dist`` the prior source's
goal distance: its priors by hand, the invariant with IQL-BFS on the exact source, its constants, the pipeline's
treatment (prediction stage, judge, fallback, ``qi_distance``), the one-line error without a distance, CLI = API."""

from __future__ import annotations

import json

import numpy as np
import pytest

import ndrql
from ndrql.errors import NdrqlError
from ndrql.pipeline.fallback import fall_back
from ndrql.pipeline.sources import exact_distance_field
from ndrql.planning import priors as P
from ndrql.planning.config import PriorConfig
from ndrql.planning.methods import build_priors, get_method
from ndrql.planning.preset import load_preset
from ndrql.planning.rules import next_table
from tests.helpers.belief_maps import GOAL, START, wall_map, wall_mask
from tests.helpers.cli import assert_one_line_error, run_cli

def test_priors_by_hand_are_d_crf_plus_d_qi_on_the_given_distance():
    blocked = np.zeros((4, 5), dtype=bool)
    blocked[1, 1:4] = True
    goal, cfg = (3, 4), PriorConfig()
    dist = np.arange(20, dtype=np.float64).reshape(4, 5)[::-1, ::-1].copy()  # any field: 0 at the goal
    pri = build_priors("IQL-NDR", blocked, (0, 0), goal, cfg=cfg, distance=dist)
    np.testing.assert_array_equal(pri.r_c, P.d_crf(blocked.shape, goal, cfg))  # Eq. 2 unchanged
    nxt = next_table(blocked)  # Eq. 5 by hand: exp(-dist(s')), s' where the action leads (stay on a wall/edge)
    flat = dist.ravel()
    by_hand = np.exp(-flat[nxt])
    np.testing.assert_allclose(pri.q0, by_hand)
    e = np.exp
    # from (0, 0) (19 away): up and left stay (19), right 18, down 14; from (0, 1) (18 away): down is the wall (18)
    np.testing.assert_allclose(np.sort(pri.q0[0]), np.sort([e(-19.0), e(-19.0), e(-18.0), e(-14.0)]))
    np.testing.assert_allclose(np.sort(pri.q0[1]), np.sort([e(-18.0), e(-18.0), e(-19.0), e(-17.0)]))
    assert not np.allclose(pri.q0, build_priors("IQL", blocked, (0, 0), goal, cfg=cfg).q0)
    assert pri.threshold is None


def test_on_the_exact_distance_its_q_table_is_iql_bfss():
    o = wall_map().astype(bool)
    goal = GOAL
    cfg = load_preset("general").configs("IQL-NDR", grid=40)[1]
    ndr = build_priors("IQL-NDR", o, START, goal, cfg=cfg, distance=exact_distance_field(o, goal))
    bfs = build_priors("IQL-BFS", o, START, goal, cfg=cfg)
    np.testing.assert_array_equal(ndr.r_c, bfs.r_c)
    free = ~o.ravel()  # the fields differ only on walls (max + 1 vs max + Manhattan), where no agent stands
    np.testing.assert_array_equal(ndr.q0[free], bfs.q0[free])
    assert not np.array_equal(ndr.q0, build_priors("IQL", o, START, goal, cfg=cfg).q0)


def test_without_a_distance_one_clear_line():
    with pytest.raises(NdrqlError) as exc:
        build_priors("IQL-NDR", np.zeros((5, 5), bool), (0, 0), (4, 4))
    msg = str(exc.value)
    assert msg == ("IQL-NDR needs a goal distance from the prior source (weights with a distance head, "
                   "or --prior-from exact)") and "\n" not in msg


def test_method_flags_constants_and_fallback():
    m = get_method("IQL-NDR")
    assert m.needs_ndr and m.needs_distance and not m.needs_region and not m.needs_guideline and not m.n_qi
    assert get_method("iql-ndr") is m and m.constants == "IQL"
    for name in ("general", "tuned", "spec"):
        p = load_preset(name)
        for n in (32, 50, 100, 256):
            assert p.configs("IQL-NDR", grid=n) == p.configs("IQL", grid=n) == p.configs("IQL-BFS", grid=n)
    ran, swaps = fall_back([m, get_method("IQL")], {"informative": False, "reasons": ["x"]}, "IQL-BFS")
    assert [x.name for x in ran] == ["IQL-BFS", "IQL"] and [s.requested for s in swaps] == ["IQL-NDR"]


def test_pipeline_asks_a_source_judges_it_and_names_the_distance():
    o, m = wall_map(), wall_mask()
    # general's constants: IQL-NDR and IQL-BFS share them (the belief preset gives IQL-BFS its own, searched on beliefs)
    a = ndrql.solve(o, start=START, goal=GOAL, methods=["IQL-NDR", "IQL-BFS"], seeds=[0, 1], hide=m, size=40,
                    predictions="exact", workers=1, preset="general")
    assert a.methods == ("IQL-NDR", "IQL-BFS") and a.info["qi_distance"] == "exact BFS distance"
    assert a.info["prediction_quality"]["informative"] and a.info["sources"]  # the judge ran
    steps = {(r.method, r.seed): r.total_steps for r in a.results}
    assert all(steps["IQL-NDR", s] == steps["IQL-BFS", s] for s in (0, 1))  # same distance, same constants


def test_cli_and_api_give_the_same_run_on_a_belief_map(ndrql_exe, tmp_path):
    np.save(tmp_path / "map.npy", wall_map())
    np.save(tmp_path / "mask.npy", wall_mask())
    r = run_cli(ndrql_exe, "plan", tmp_path / "map.npy", "--start", "5,5", "--goal", "5,34", "--hide",
                tmp_path / "mask.npy", "--method", "IQL-NDR", "--prior-from", "exact", "--seeds", "2", "--size", "40",
                "--json", tmp_path / "out.json")
    assert r.returncode == 0, r.stderr
    assert "IQL-NDR: Eq. 5's distance from the prior source: exact BFS distance" in r.stdout
    doc = json.loads((tmp_path / "out.json").read_text())
    api = ndrql.solve(str(tmp_path / "map.npy"), start=START, goal=GOAL, methods=["IQL-NDR"], seeds=2, size=40,
                      hide=str(tmp_path / "mask.npy"), predictions="exact")
    assert doc["methods"] == ["IQL-NDR"] and doc["qi_distance"] == "exact BFS distance"
    assert [x["total_steps"] for x in doc["runs"]] == [x.total_steps for x in api.results]


def test_cli_a_source_without_a_distance_exits_2_with_one_line(ndrql_exe, tmp_path):
    np.save(tmp_path / "map.npy", wall_map())
    r = run_cli(ndrql_exe, "plan", tmp_path / "map.npy", "--start", "5,5", "--goal", "5,34", "--method", "IQL-NDR",
                "--prior-from", "head", "--size", "40", "--fallback", "none")
    assert_one_line_error(r, "IQL-NDR needs a goal distance from the prior source")
