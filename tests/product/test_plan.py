"""``ndrql plan`` with the pretrained model on every map format, run as the real console script.

Each test writes its own map (PNG, ROS map_server YAML + PGM, MovingAI .map + .scen) or uses a
dataset sample, plans with the default NDR-QL, and checks the summary, the JSON and the figure:
the learned path joins start and goal without collisions and is no shorter than A*; the JSON has
the Q-learning fields, the NDR-QI threshold and the time per stage.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from ndrql.maps.astar import astar4, path_is_valid

from helpers.cli import run_cli


def rooms(h: int, w: int) -> np.ndarray:
    """A ``h x w`` map with a border and two walls with doors (any size and aspect ratio)."""
    m = np.zeros((h, w), dtype=bool)
    m[0, :] = m[-1, :] = m[:, 0] = m[:, -1] = True
    t = max(2, min(h, w) // 25)  # wall thickness
    r = h // 3
    m[r:r + t, : int(w * 0.7)] = True  # wall from the left, door on the right
    c = w // 2
    m[r + t:, c:c + t] = True  # wall down from the first one ...
    m[int(h * 0.75):int(h * 0.75) + max(t, h // 10), c:c + t] = False  # ... with a door near the bottom
    return m


def check_plan_outputs(r, out_json, out_png, method="NDR-QL"):
    """Summary lines, JSON fields and figure of a converged single-run plan; returns the JSON."""
    assert r.returncode == 0, r.stderr
    assert f"{method} seed 0: converged after" in r.stdout, r.stdout
    assert "A* optimum:" in r.stdout and "NDR-QI threshold" in r.stdout
    assert "time (s): load" in r.stdout and "predict" in r.stdout and "priors" in r.stdout and "learn" in r.stdout
    data = json.loads(out_json.read_text())
    blocked = np.array([[ch == "#" for ch in row] for row in data["grid"]])
    start, goal = tuple(data["start"]), tuple(data["goal"])
    assert data["astar_length"] == astar4(blocked, start, goal).moves
    assert data["methods"] == [method] and data["seeds"] == [0]
    run = data["runs"][0]
    for key in ("converged", "convergence_episode", "convergence_steps", "episodes", "total_steps", "path",
                "path_length", "astar_length", "length_ratio", "shortest_success_length", "longest_success_length",
                "first_success_episode", "threshold"):
        assert key in run
    assert run["converged"] and run["convergence_steps"] > 0
    path = [tuple(c) for c in run["path"]]
    assert path[0] == start and path[-1] == goal and path_is_valid(blocked, path)
    assert run["path_length"] == len(path) - 1 >= data["astar_length"]
    assert run["length_ratio"] == pytest.approx(run["path_length"] / data["astar_length"])
    assert data["ndr_qi_threshold"][method] == run["threshold"]
    assert set(data["timings"]["wall"]) >= {"load", "predict", "priors", "learn"}
    assert data["weights"]
    assert out_png.stat().st_size > 5000
    with Image.open(out_png) as im:
        assert im.format == "PNG" and im.size[0] > 300
    return data


def test_plan_png_map(ndrql_exe, model_weights, tmp_path):
    m = rooms(150, 230)  # not 201x201, not square: the model sees it resized and padded
    path = tmp_path / "rooms.png"
    Image.fromarray(np.where(m, 0, 255).astype(np.uint8)).save(path)
    out, png = tmp_path / "o" / "plan.json", tmp_path / "o" / "plan.png"
    r = run_cli(ndrql_exe, "plan", path, "--start", "20,20", "--goal", "130,210", "--json", out, "--png", png)
    data = check_plan_outputs(r, out, png)
    assert data["map"]["height"] == 150 and data["map"]["width"] == 230
    side = data["planning_grid"]["cell_px"][0]  # the safe grid: square cells, size on the longer side (230 px)
    assert data["planning_grid"]["cell_px"] == [side, side] and side == pytest.approx(230 / data["planning_grid"]["size"])
    pix = data["runs"][0]["path_pixels"]  # cell centres in map pixels
    assert pix[0] == pytest.approx([(data["start"][0] + 0.5) * side - 0.5, (data["start"][1] + 0.5) * side - 0.5])
    route = data["runs"][0]["route"]
    assert route["pixels"][0] == [20, 20] and route["pixels"][-1] == [130, 210]  # the final path joins the points
    assert data["runs"][0]["success"] is True and data["runs"][0]["collisions"] == []
    assert "path_world" not in data["runs"][0]  # a PNG has no resolution/origin
    assert data["source_start"] == [20, 20] and data["source_goal"] == [130, 210]


def test_plan_ros_yaml_map(ndrql_exe, model_weights, tmp_path):
    m = rooms(180, 180)
    gray = np.where(m, 0, 254).astype(np.uint8)
    gray[:, 170:] = 205  # unknown strip at the right: counts as obstacle
    Image.fromarray(gray).save(tmp_path / "office.pgm")
    (tmp_path / "office.yaml").write_text(
        "image: office.pgm\nresolution: 0.05\norigin: [-4.5, -4.5, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n", encoding="utf-8")
    out, png = tmp_path / "ros.json", tmp_path / "ros.png"
    r = run_cli(ndrql_exe, "plan", tmp_path / "office.yaml", "--start", "15,15", "--goal", "165,150", "--json", out,
                "--png", png)
    data = check_plan_outputs(r, out, png)
    assert data["map"]["resolution"] == 0.05 and data["map"]["origin"] == [-4.5, -4.5, 0.0]
    # world poses of the final path (metres, radians): the first is the start pixel's centre
    run = data["runs"][0]
    (r0, c0), (x0, y0, yaw0) = run["route"]["pixels"][0], run["path_world"][0]
    assert (r0, c0) == (15, 15)
    assert x0 == pytest.approx(-4.5 + (c0 + 0.5) * 0.05) and y0 == pytest.approx(-4.5 + (180 - r0 - 0.5) * 0.05)
    (r1, c1), (x1, y1, _) = run["route"]["pixels"][1], run["path_world"][1]
    assert yaw0 == pytest.approx(np.arctan2(y1 - y0, x1 - x0), abs=1e-3)  # facing the next pose
    assert len(run["path_world"]) == len(run["route"]["pixels"])
    assert run["route"]["length_m"]["final"] == pytest.approx(run["route"]["length_px"]["final"] * 0.05, abs=1e-3)


def _movingai(tmp_path, m):
    rows = ["".join("@" if b else "." for b in row) for row in m]
    (tmp_path / "arena.map").write_text(
        f"type octile\nheight {m.shape[0]}\nwidth {m.shape[1]}\nmap\n" + "\n".join(rows) + "\n", encoding="ascii")
    # .scen: x = column, y = row; two scenarios, the second one is used
    (tmp_path / "arena.map.scen").write_text(
        "version 1\n"
        f"0\tarena.map\t{m.shape[1]}\t{m.shape[0]}\t5\t5\t10\t10\t7.07106781\n"
        f"0\tarena.map\t{m.shape[1]}\t{m.shape[0]}\t4\t4\t{m.shape[1] - 6}\t{m.shape[0] - 6}\t200.0\n", encoding="ascii")


def test_plan_movingai_map_with_scenario(ndrql_exe, model_weights, tmp_path):
    m = rooms(120, 100)
    _movingai(tmp_path, m)
    out, png = tmp_path / "mai.json", tmp_path / "mai.png"
    r = run_cli(ndrql_exe, "plan", tmp_path / "arena.map", "--scen", tmp_path / "arena.map.scen", "--index", "1",
                "--json", out, "--png", png)
    data = check_plan_outputs(r, out, png)
    assert data["source_start"] == [4, 4] and data["source_goal"] == [114, 94]  # (row, col) from (x, y)
    assert data["scenario"] == {"file": str(tmp_path / "arena.map.scen"), "index": 1, "optimal_length": 200.0}
    # FILE:K is the same as --index K (the form `ndrql astar` uses)
    r2 = run_cli(ndrql_exe, "plan", tmp_path / "arena.map", "--scen", f"{tmp_path / 'arena.map.scen'}:1",
                 "--method", "QL")
    assert r2.returncode == 0, r2.stderr
    assert "QL seed 0: converged" in r2.stdout and f"A* optimum: {data['astar_length']} moves" in r2.stdout


@pytest.mark.data
def test_plan_dataset_sample(ndrql_exe, model_weights, dataset_root, tmp_path):
    out, png = tmp_path / "s.json", tmp_path / "s.png"
    r = run_cli(ndrql_exe, "plan", "--sample", f"{dataset_root}:seen:0", "--json", out, "--png", png)
    data = check_plan_outputs(r, out, png)
    assert data["sample"]["split"] == "seen" and data["sample"]["index"] == 0
    assert data["map"]["height"] == data["map"]["width"] == 201


def test_compare_table_and_figure(ndrql_exe, model_weights, tmp_path):
    m = rooms(201, 201)
    np.save(tmp_path / "m.npy", m)
    out, png = tmp_path / "c.json", tmp_path / "c.png"
    r = run_cli(ndrql_exe, "plan", tmp_path / "m.npy", "--start", "20,20", "--goal", "180,180",
                "--compare", "QL,IQL,NDR-QL", "--seeds", "3", "--json", out, "--png", png)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    for name in ("QL", "IQL", "NDR-QL"):
        assert any(line.split()[:2] == [name, "3/3"] for line in lines), r.stdout
    data = json.loads(out.read_text())
    assert [x["method"] for x in data["runs"]] == ["QL"] * 3 + ["IQL"] * 3 + ["NDR-QL"] * 3
    assert list(data["ndr_qi_threshold"]) == ["NDR-QL"]
    with Image.open(png) as im:
        assert im.size[0] > 2.5 * im.size[1]  # one panel per method plus the convergence panel


def _plan_runs(ndrql_exe, args: list, out) -> list[dict]:
    """``ndrql plan *args --json out``: the runs, without their wall times."""
    r = run_cli(ndrql_exe, "plan", *args, "--json", out)
    assert r.returncode == 0, r.stderr
    runs = json.loads(out.read_text())["runs"]
    for x in runs:
        x.pop("wall_time")
    return runs


def test_weights_option_and_prior_file_agree(ndrql_exe, tmp_path):
    """A map-mode model (the paper's): --weights gives the same runs as --prior-from the arrays
    predict_priors returns for it (both average the map-resolution arrays onto the grid)."""
    from ndrql.pipeline.predictions import predict_priors

    m = rooms(100, 140)
    np.save(tmp_path / "m.npy", m)
    region, guideline = predict_priors(m, (10, 10), (90, 130), weights="paper")
    np.savez(tmp_path / "pred.npz", region=region, guideline=guideline)
    common = [tmp_path / "m.npy", "--start", "10,10", "--goal", "90,130", "--seeds", "2", "--workers", "1",
              "--preset", "tuned"]
    outs = [_plan_runs(ndrql_exe, [*common, *extra], tmp_path / f"{i}.json")
            for i, extra in enumerate((["--weights", "paper"], ["--prior-from", tmp_path / "pred.npz"]))]
    assert outs[0] == outs[1] and outs[0][0]["converged"]


def test_predict_then_plan_with_its_file_plans_as_plan_does(ndrql_exe, model_weights, tmp_path):
    """The grid-mode model (the default general weights): ``ndrql predict`` predicts on the very safe grid
    plan builds (same auto size), writes its per-cell arrays, and ``plan --prior-from`` that file gives
    the same runs as ``plan`` with the model; predict_priors gives the same map-resolution arrays."""
    from ndrql.pipeline.predictions import load_predictions, predict_priors

    m = rooms(100, 140)
    np.save(tmp_path / "m.npy", m)
    pts = ["--start", "10,10", "--goal", "90,130"]
    r = run_cli(ndrql_exe, "predict", tmp_path / "m.npy", *pts, "--out", tmp_path / "p", "--weights", model_weights)
    assert r.returncode == 0, r.stderr
    assert "grid-mode model: saw the safe" in r.stdout
    common = [tmp_path / "m.npy", *pts, "--seeds", "2", "--workers", "1"]
    with_model = _plan_runs(ndrql_exe, [*common, "--weights", model_weights], tmp_path / "a.json")
    from_file = _plan_runs(ndrql_exe, [*common, "--prior-from", tmp_path / "p" / "prediction.npz"], tmp_path / "b.json")
    assert with_model == from_file and with_model[0]["converged"]
    given = load_predictions(tmp_path / "p" / "prediction.npz")
    region, guideline = predict_priors(m, (10, 10), (90, 130), weights=model_weights)
    assert np.allclose(given.region, region, atol=1e-6) and np.allclose(given.guideline, guideline, atol=1e-6)
    # each map pixel holds its cell's value
    g = given.grid
    cell = 140 / g.size
    assert region[10, 10] == pytest.approx(g.region[int(10.5 / cell), int(10.5 / cell)])


def test_a_prior_file_from_another_grid_is_averaged_onto_plans_grid(ndrql_exe, model_weights, tmp_path):
    """Grid arrays made on another grid (``predict --size 64``, plan on 50) are not used as they are: plan
    averages the map-resolution arrays onto its own grid and says so in its JSON."""
    m = rooms(100, 140)
    np.save(tmp_path / "m.npy", m)
    pts = ["--start", "10,10", "--goal", "90,130"]
    r = run_cli(ndrql_exe, "predict", tmp_path / "m.npy", *pts, "--out", tmp_path / "p", "--size", "64")
    assert r.returncode == 0, r.stderr
    for size, expect in (("64", "as given"), ("50", "averaged from the map's pixels")):
        out = tmp_path / f"{size}.json"
        r = run_cli(ndrql_exe, "plan", tmp_path / "m.npy", *pts, "--size", size, "--seeds", "1",
                    "--prior-from", tmp_path / "p" / "prediction.npz", "--json", out)
        assert r.returncode == 0, r.stderr
        assert json.loads(out.read_text())["prior_grid"] == expect
        assert f"predictions: {tmp_path / 'p' / 'prediction.npz'}" in r.stdout and expect.split()[0] in r.stdout


def test_point_in_a_blocked_cell_moves_with_a_warning(ndrql_exe, tmp_path):
    """A free pixel whose planning cell is mostly obstacle: moved to the nearest free cell (SPEC 1), one warning."""
    m = np.zeros((100, 100), dtype=bool)
    m[40:60, 40:60] = True
    m[50, 50] = False  # a free pixel inside the block
    np.save(tmp_path / "m.npy", m)
    out = tmp_path / "w.json"
    r = run_cli(ndrql_exe, "plan", tmp_path / "m.npy", "--start", "50,50", "--goal", "95,95", "--method", "QL",
                "--json", out, "--grid", "area", "--size", "50")  # the paper's rule: the cell is at least half obstacle
    assert r.returncode == 0, r.stderr
    assert r.stderr.startswith("ndrql: warning: start (50, 50) falls in blocked planning cell (25, 25)")
    data = json.loads(out.read_text())
    assert data["snapped"] == {"start": True, "goal": False} and data["runs"][0]["converged"]


def test_json_to_stdout_and_a_point_the_model_input_loses(ndrql_exe, model_weights, tmp_path):
    """``--json -`` keeps stdout pure JSON; a start in a 1-px hole of a 603x603 map vanishes in the
    model's 201x201 input: one warning, the JSON says where the model saw it, planning still works.
    (The paper model: it sees the map resized to 201 px; the default general model sees the grid.)"""
    m = np.zeros((603, 603), dtype=bool)
    m[0:60, 0:60] = True
    m[31, 31] = False  # a single free pixel inside a block: gone after resizing by 1/3
    m[0:60, 30:33] = False  # ... reachable through a 3-px corridor so planning can start there
    np.save(tmp_path / "m.npy", m)
    r = run_cli(ndrql_exe, "plan", tmp_path / "m.npy", "--start", "31,31", "--goal", "590,590", "--json", "-",
                "--weights", "paper")
    assert r.returncode == 0, r.stderr
    data = json.loads(r.stdout)
    assert data["model_input"]["scale"] == pytest.approx(1 / 3)
    assert data["model_input"]["moved"] == {"start": False, "goal": False}  # the 3-px corridor survives at 1/3
    assert "model's 201x201 input" not in r.stderr
    assert "NDR-QL seed 0: converged" in r.stderr and "time (s):" in r.stderr
    m[0:60, 30:33] = True  # now the hole is isolated in the model input
    m[0:29, 31] = False  # a 1-px corridor: free on the map, blocked after resizing
    np.save(tmp_path / "m.npy", m)
    r = run_cli(ndrql_exe, "plan", tmp_path / "m.npy", "--start", "20,31", "--goal", "590,590", "--json", "-",
                "--method", "N-Q", "--size", "201", "--weights", "paper")
    assert r.returncode == 0, r.stderr
    data = json.loads(r.stdout)
    assert data["model_input"]["moved"]["start"] is True
    assert "ndrql: warning: start 20,31 falls on an obstacle of the model's 201x201 input" in r.stderr
