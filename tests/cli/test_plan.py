"""``ndrql plan`` run as the real console script: stdout, stderr, exit codes and the JSON."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ndrql.maps.astar import astar4, path_is_valid

from helpers.cli import assert_one_line_error, run_cli


@pytest.fixture
def room_npy(tmp_path):
    """A 100x100 map (2 px per planning cell at --size 50) with a wall and a gap."""
    m = np.zeros((100, 100), dtype=bool)
    m[40:44, :70] = True
    path = tmp_path / "room.npy"
    np.save(path, m)
    return path


def check_json(data, seeds, methods):
    blocked = np.array([[ch == "#" for ch in row] for row in data["grid"]])
    start, goal = tuple(data["start"]), tuple(data["goal"])
    assert data["astar_length"] == astar4(blocked, start, goal).moves
    assert data["seeds"] == seeds and data["methods"] == methods
    assert len(data["runs"]) == len(seeds) * len(methods)
    for run_ in data["runs"]:
        assert run_["converged"]
        path = [tuple(c) for c in run_["path"]]
        assert path[0] == start and path[-1] == goal
        assert path_is_valid(blocked, path)
        assert run_["path_length"] == len(path) - 1 >= data["astar_length"]
    return blocked


def test_plan_map_file_json_and_png(ndrql_exe, room_npy, tmp_path):
    out, png = tmp_path / "o" / "plan.json", tmp_path / "plan.png"
    r = run_cli(ndrql_exe, "plan", room_npy, "--start", "0,0", "--goal", "99,99", "--method", "IQL", "--seeds", "3",
                "--seed", "5", "--json", out, "--png", png, "--records")
    assert r.returncode == 0, r.stderr
    assert "IQL seed 5: converged" in r.stdout and "A* optimum" in r.stdout
    data = json.loads(out.read_text())
    check_json(data, [5, 6, 7], ["IQL"])
    assert len(data["runs"][0]["records"]["steps"]) == data["runs"][0]["episodes"]
    from ndrql.planning.preset import load_preset, plan_default_preset

    # plan's default preset (the one searched for the default weights), its entry for this grid's size
    ql, pc = load_preset(plan_default_preset()).configs("IQL", grid=max(data["planning_size"]))
    assert data["config"]["gamma"] == ql.gamma and data["prior_config"]["r_max"] == pc.r_max
    assert png.stat().st_size > 1000


def test_same_seed_same_json_any_workers(ndrql_exe, room_npy, tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    common = [room_npy, "--start", "0,0", "--goal", "99,99", "--method", "QL", "--seeds", "4"]
    assert run_cli(ndrql_exe, "plan", *common, "--workers", "1", "--json", a).returncode == 0
    assert run_cli(ndrql_exe, "plan", *common, "--workers", "2", "--json", b).returncode == 0
    ra, rb = (json.loads(p.read_text())["runs"] for p in (a, b))
    for x, y in zip(ra, rb):
        x.pop("wall_time"), y.pop("wall_time")
    assert ra == rb


def test_compare_prints_a_table(ndrql_exe, room_npy):
    r = run_cli(ndrql_exe, "plan", room_npy, "--start", "0,0", "--goal", "99,99", "--compare", "QL,IQL,O-QL",
                "--seeds", "3")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert any(line.startswith("method") and "steps mean" in line for line in lines)
    for m in ("QL", "IQL", "O-QL"):
        assert any(line.split()[:2] == [m, "3/3"] for line in lines), r.stdout


def test_not_converged_is_reported(ndrql_exe, room_npy, tmp_path):
    out = tmp_path / "nc.json"
    r = run_cli(ndrql_exe, "plan", room_npy, "--start", "0,0", "--goal", "99,99", "--method", "QL",
                "--max-episodes", "2", "--json", out)
    assert r.returncode == 0, r.stderr
    assert "NOT converged" in r.stdout
    data = json.loads(out.read_text())
    assert data["runs"][0]["converged"] is False and data["summary"]["QL"]["not_converged"] == 1


@pytest.mark.parametrize(
    "args,needle",
    [
        (["--method", "DQN"], "valid methods: QL, D-C, N-C, D-Q, N-Q, IQL, O-QL, NDR-QL"),
        (["--compare", "QL,nope"], "unknown method 'nope'"),
        (["--method", "NDR-QL", "--weights", "/nonexistent/ndr.pt"], "missing model weights: /nonexistent/ndr.pt"),
        (["--seeds", "0"], "--seeds must be an integer in 1..10,000, got 0"),
        (["--gamma", "1.5"], "gamma"),
        (["--guideline-ties", "2"], "--guideline-ties must be a finite number in [0, 0.95]"),
        (["--region-dilation", "20"], "--region-dilation must be an integer in 0..10"),
        (["--region-dilation", "1.5"], "--region-dilation: invalid int value"),
        (["--method", "N-C", "--prior-from", "missing.npz"], "prior file not found"),
    ],
)
def test_bad_input_one_line_exit_2(ndrql_exe, room_npy, args, needle):
    r = run_cli(ndrql_exe, "plan", room_npy, "--start", "0,0", "--goal", "99,99", *args)
    assert_one_line_error(r, needle)


def test_unreachable_goal_exit_2(ndrql_exe, tmp_path):
    m = np.zeros((100, 100), dtype=bool)
    m[48:52, :] = True
    path = tmp_path / "wall.npy"
    np.save(path, m)
    r = run_cli(ndrql_exe, "plan", path, "--start", "0,0", "--goal", "99,99")
    assert_one_line_error(r, "not connected on the map itself")


def test_prior_file_with_wrong_shape_or_keys(ndrql_exe, room_npy, tmp_path):
    bad = tmp_path / "bad.npz"
    np.savez(bad, region=np.ones((10, 10)), guideline=np.ones((10, 10)))
    r = run_cli(ndrql_exe, "plan", room_npy, "--start", "0,0", "--goal", "99,99", "--method", "NDR-QL",
                "--prior-from", bad)
    assert_one_line_error(r, "map's resolution")
    np.savez(bad, region=np.ones((100, 100)))
    r = run_cli(ndrql_exe, "plan", room_npy, "--start", "0,0", "--goal", "99,99", "--method", "N-Q",
                "--prior-from", bad)
    assert_one_line_error(r, "guideline")


@pytest.mark.data
def test_issue_command_on_dataset_sample(ndrql_exe, dataset_root, tmp_path):
    """The issue's acceptance command: IQL, 10 seeds, SEEN 0, JSON passes the invariants."""
    out = tmp_path / "out.json"
    r = run_cli(ndrql_exe, "plan", "--sample", f"{dataset_root}:seen:0", "--method", "IQL", "--seeds", "10",
                "--json", out)
    assert r.returncode == 0, r.stderr
    data = json.loads(out.read_text())
    check_json(data, list(range(10)), ["IQL"])
    assert data["sample"]["split"] == "seen" and data["planning_size"] == [50, 50]


@pytest.mark.data
def test_ndr_ql_with_labels_as_predictions(ndrql_exe, dataset_root, tmp_path):
    """--prior-from with the sample's own region/guideline labels (a perfect NDR model)."""
    from ndrql.dataset.layout import load_sample

    s = load_sample(dataset_root, "seen", 0)
    npz = tmp_path / "pred.npz"
    np.savez(npz, region=s.region.astype(np.float32), guideline=s.guideline.astype(np.float32))
    out = tmp_path / "ndr.json"
    r = run_cli(ndrql_exe, "plan", "--sample", f"{dataset_root}:seen:0", "--compare", "QL,NDR-QL", "--seeds", "4",
                "--prior-from", npz, "--json", out)
    assert r.returncode == 0, r.stderr
    assert "NDR-QL: NDR-QI threshold" in r.stdout
    data = json.loads(out.read_text())
    check_json(data, [0, 1, 2, 3], ["QL", "NDR-QL"])
    s = data["summary"]
    assert s["NDR-QL"]["convergence_steps"]["mean"] < s["QL"]["convergence_steps"]["mean"]
