"""A plan on a map the planner does not fully know: priors from the belief, learning on the truth (ndrql.pipeline.belief)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

import ndrql
from ndrql.errors import MapFormatError, NdrqlError, NoPathError, PointError
from ndrql.maps.belief import Belief
from ndrql.planning.methods import build_priors
from ndrql.planning.runner import run_plan
from tests.helpers.belief_maps import GOAL, START, wall_map, wall_mask
from tests.helpers.cli import assert_one_line_error, run_cli

def test_priors_read_the_belief_and_the_agent_learns_on_the_truth():
    o, m = wall_map(), wall_mask()
    report = ndrql.solve(o, start=START, goal=GOAL, methods=["IQL-BFS"], seeds=[3], hide=m, size=40)
    run = report.results[0]
    truth, belief = report.grid.blocked, report.setup.belief.blocked
    assert truth[0:34, 20].all() and not belief[0:12, 20].any() and belief[12:34, 20].all()
    rec = report.info["belief"]
    assert rec["true_optimum"] == run.astar_length == 2 * (34 - 5) + 29 and rec["belief_optimum"] == 29
    assert rec["unknown_share"] == pytest.approx(((m == 1) & (o == 0)).sum() / (o == 0).sum(), abs=1e-3)
    assert rec["cells_wrong"] == {"blocked_believed_free": 12, "free_believed_blocked": 0}
    # the same run by hand: IQL-BFS's priors built on the belief grid, Q-learning on the true grid
    ql, pc = report.request.constants("IQL-BFS", 40)
    pri = build_priors("IQL-BFS", belief, report.grid.start, report.grid.goal, cfg=pc)
    by_hand = run_plan(truth, report.grid.start, report.grid.goal, "IQL-BFS", 3, ql, priors=pri)
    assert (run.convergence_steps, run.total_steps) == (by_hand.convergence_steps, by_hand.total_steps)
    known = ndrql.solve(o, start=START, goal=GOAL, methods=["IQL-BFS"], seeds=[3], size=40)
    assert known.setup.belief is None and "belief" not in known.info
    assert known.results[0].total_steps != run.total_steps  # what the planner knows changes the run


def test_a_mask_of_zeros_plans_as_the_known_map():
    o = wall_map()
    a = ndrql.solve(o, start=START, goal=GOAL, methods=["IQL-BFS", "IQL"], seeds=[0, 1], size=40, workers=1)
    b = ndrql.solve(o, start=START, goal=GOAL, methods=["IQL-BFS", "IQL"], seeds=[0, 1], size=40, hide=np.zeros_like(o),
                    workers=1)
    assert [r.total_steps for r in a.results] == [r.total_steps for r in b.results]
    assert b.info["belief"]["unknown_px"] == 0


def test_oracle_predictions_come_from_the_truth():
    o, m = wall_map(), wall_mask()
    report = ndrql.solve(o, start=START, goal=GOAL, methods=["NDR-QL"], seeds=[0], hide=m, size=40, predictions="oracle",
                         fallback=None)
    region = np.asarray(report.region) if report.region is not None else None
    assert report.results[0].converged and region is not None
    assert report.results[0].path_length == report.info["belief"]["true_optimum"]


def test_an_outdated_belief_with_a_door_closed_that_is_open():
    o = wall_map()
    believed = o.astype(bool).copy()
    believed[34:40, 20] = True  # the belief closes the only way round
    with pytest.raises(NoPathError, match="not connected"):
        ndrql.solve(o, start=START, goal=GOAL, methods=["IQL-BFS"], seeds=[0], size=40,
                    hide=Belief(believed, np.zeros_like(believed), kind="outdated"))
    believed[0:5, 20] = False  # and opens one that is closed: the belief connects, the truth the long way round
    report = ndrql.solve(o, start=START, goal=GOAL, methods=["IQL-BFS"], seeds=[0], size=40,
                         hide=Belief(believed, np.zeros_like(believed), kind="outdated"))
    assert report.info["belief"]["kind"] == "outdated" and report.info["belief"]["belief_optimum"] == 31
    assert report.results[0].astar_length == 87


def test_the_truth_must_connect_at_the_size_the_belief_chose():
    o = wall_map()
    o[34:40, 20] = 1  # the wall closes the map; the mask hides a part of it: only the belief sees a way
    with pytest.raises(NoPathError, match="connect on the belief map but not on the true map"):
        ndrql.solve(o, start=START, goal=GOAL, methods=["IQL"], seeds=[0], hide=wall_mask(), size=40)


def test_bad_masks_are_one_clear_error():
    o = wall_map()
    with pytest.raises(MapFormatError, match="is 39x40 .* the map is 40x40"):
        ndrql.build_request(o, START, GOAL, methods=["IQL"], hide=np.zeros((39, 40)))
    m = np.zeros_like(o)
    m[5, 5] = 1
    with pytest.raises(PointError, match="start 5,5 is unknown to the planner"):
        ndrql.build_request(o, START, GOAL, methods=["IQL"], hide=m)
    everything = (o == 0).astype(np.uint8)
    everything[START] = everything[GOAL] = 0
    with pytest.raises(MapFormatError, match="hides every free pixel"):
        ndrql.build_request(o, START, GOAL, methods=["IQL"], hide=everything)
    with pytest.raises(NdrqlError, match="not a ROS .yaml"):
        ndrql.build_request(o, START, GOAL, methods=["IQL"], unknown="free")


def _files(tmp_path):
    np.save(tmp_path / "map.npy", wall_map())
    np.save(tmp_path / "mask.npy", wall_mask())
    return tmp_path / "map.npy", tmp_path / "mask.npy"


def test_cli_and_api_give_the_same_steps(ndrql_exe, tmp_path):
    mp, mask = _files(tmp_path)
    r = run_cli(ndrql_exe, "plan", mp, "--start", "5,5", "--goal", "5,34", "--hide", mask, "--compare", "IQL,IQL-BFS",
                "--seeds", "2", "--size", "40", "--json", tmp_path / "out.json")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "out.json").read_text())
    api = ndrql.solve(str(mp), start=START, goal=GOAL, methods=["IQL", "IQL-BFS"], seeds=2, size=40, hide=str(mask))
    assert [x["total_steps"] for x in doc["runs"]] == [x.total_steps for x in api.results]
    assert doc["belief"]["true_optimum"] == 87 and doc["belief"]["belief_optimum"] == 29


def test_cli_bad_masks_exit_2_with_one_line(ndrql_exe, tmp_path):
    mp, mask = _files(tmp_path)
    np.save(tmp_path / "small.npy", np.zeros((30, 40)))
    Image.fromarray(np.full((40, 40), 255, np.uint8)).save(tmp_path / "all.png")
    (tmp_path / "junk.npy").write_text("not a mask")
    base = ("plan", mp, "--start", "5,5", "--goal", "5,34", "--method", "IQL", "--size", "40")
    assert_one_line_error(run_cli(ndrql_exe, *base, "--hide", tmp_path / "small.npy"), "the map is 40x40")
    assert_one_line_error(run_cli(ndrql_exe, *base, "--hide", tmp_path / "all.png"), "start 5,5 is unknown")
    assert_one_line_error(run_cli(ndrql_exe, *base, "--hide", tmp_path / "junk.npy"), "is not a mask")
    assert_one_line_error(run_cli(ndrql_exe, *base, "--unknown", "free"), "not a ROS .yaml")


def _ros(tmp_path) -> tuple:
    img = np.full((40, 60), 254, np.uint8)
    img[:, 30] = 0
    img[30:40, 30] = 205  # the wall's bottom is unknown space
    Image.fromarray(img).save(tmp_path / "room.pgm")
    (tmp_path / "room.yaml").write_text("image: room.pgm\nresolution: 0.1\norigin: [0.0, 0.0, 0.0]\n"
                                        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return tmp_path / "room.yaml"


def test_ros_unknown_space_as_obstacle_or_free(tmp_path):
    yml = _ros(tmp_path)
    with pytest.raises(NoPathError):
        ndrql.solve(str(yml), start=(5, 5), goal=(5, 55), methods=["IQL"], seeds=[0], size=60)
    report = ndrql.solve(str(yml), start=(5, 5), goal=(5, 55), methods=["IQL-BFS"], seeds=[0], size=60, unknown="free")
    rec = report.info["belief"]
    assert rec["kind"] == "ros" and rec["unknown_px"] == 10 and "truth behind it is not known" in rec["note"]
    assert report.results[0].converged and rec["true_optimum"] == rec["belief_optimum"] == 2 * (30 - 5) + 50


def test_the_paper_grid_takes_a_belief_too():
    report = ndrql.solve(wall_map(), start=START, goal=GOAL, methods=["IQL-BFS"], seeds=[0], hide=wall_mask(), grid="area",
                         size=40)
    rec = report.info["belief"]
    assert report.setup.rule == "area" and rec["true_optimum"] == 87 and rec["belief_optimum"] == 29
    assert report.results[0].converged


def test_a_ros_start_in_unknown_space_with_unknown_free(tmp_path):
    yml = _ros(tmp_path)
    with pytest.raises(PointError, match="unknown to the planner .* the map's unknown space"):
        ndrql.build_request(str(yml), (35, 30), (5, 55), methods=["IQL"], unknown="free")
