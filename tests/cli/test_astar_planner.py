"""``ndrql astar`` as a planner in its own right (issue 55): world points, robot radius with --octile, a
nav_msgs/Path, a summary of at most a screen, scenario batches with JSONL; ``ndrql.astar`` is the same
search. In process through ``main()`` (nothing here imports torch)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml
from PIL import Image

import ndrql
from ndrql.cli import main
from ndrql.errors import NdrqlError
from ndrql.maps.astar import astar8
from ndrql.maps.readers import load_map
from ndrql.maps.safe import inflate
from ndrql.maps.world import world_to_pixel

RES = 0.05
ORIGIN = (-8.0, -1.0)


@pytest.fixture
def room(tmp_path, monkeypatch):
    """A 10 x 6 m ROS room (0.05 m per pixel) with a wall and a 1 m door; the test runs in its folder."""
    img = np.full((120, 200), 254, np.uint8)
    img[:, 100:103] = 0
    img[50:70, 100:103] = 254
    Image.fromarray(img).save(tmp_path / "room.pgm")
    (tmp_path / "room.yaml").write_text(f"image: room.pgm\nresolution: {RES}\norigin: [{ORIGIN[0]}, {ORIGIN[1]}, 0.0]\n"
                                        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    monkeypatch.chdir(tmp_path)
    return tmp_path


ROS = ("room.yaml", "--start-world", "-7,2", "--goal-world", "1.5,4.5", "--robot-radius", "0.2")


def cli(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_ros_job_octile_with_radius_writes_a_nav_path(room, capsys):
    code, out, err = cli(capsys, "astar", *ROS, "--octile", "--path-out", "p.yaml", "--json", "a.json")
    assert code == 0, err
    assert len(out.splitlines()) <= 10 and "Q-learning" not in out + err  # a summary, no plan warning
    assert "path (" not in out  # the path only on request
    assert "time (s): map" in out and ", output " in out  # the outputs' time is in the time line
    msg = yaml.safe_load((room / "p.yaml").read_text())
    assert msg["header"]["frame_id"] == "map" and len(msg["poses"]) > 10
    first, last = msg["poses"][0]["pose"]["position"], msg["poses"][-1]["pose"]["position"]
    assert math.hypot(first["x"] + 7, first["y"] - 2) < RES and math.hypot(last["x"] - 1.5, last["y"] - 4.5) < RES
    # the search ran on the map inflated by 4 px (0.2 m): its length is that map's octile optimum
    grid_map = load_map(room / "room.yaml")
    inflated = inflate(grid_map.obstacles, 0.2 / RES)
    s, g = world_to_pixel(grid_map, -7, 2), world_to_pixel(grid_map, 1.5, 4.5)
    data = json.loads((room / "a.json").read_text())
    assert data["method"] == "A*-octile" and data["path_length"] == pytest.approx(astar8(inflated, s, g).cost)
    assert data["path_length"] > astar8(grid_map.obstacles, s, g).cost  # the radius made it go round the door's edge
    assert all(not inflated[r, c] for r, c in data["path"]) and data["success"]


def test_cli_equals_api(room, capsys):
    assert cli(capsys, "astar", *ROS, "--json", "grid.json")[0] == 0
    data = json.loads((room / "grid.json").read_text())
    run = ndrql.astar("room.yaml", start_world=(-7, 2), goal_world=(1.5, 4.5), robot_radius=0.2)
    assert isinstance(run, ndrql.AStarRun) and run.method == "A*" == data["method"]
    assert run.path == data["path"] and run.path_length == data["length"]
    assert [[round(float(v), 4) for v in p] for p in run.poses] == data["route"]["poses"]
    octile = ndrql.astar("room.yaml", start_world=(-7, 2), goal_world=(1.5, 4.5), robot_radius=0.2, octile=True)
    request = ndrql.build_request("room.yaml", start_world=(-7, 2), goal_world=(1.5, 4.5), robot_radius=0.2,
                                  methods="QL", smooth=False)
    assert ndrql.astar(request, octile=True).path == octile.path  # a request as plan's: the same search
    assert octile.success and octile.poses.shape[1] == 3 and octile.grid is None
    with pytest.raises(NdrqlError, match="whole plan"):
        ndrql.astar(request, robot_radius=0.1)
    with pytest.raises(NdrqlError, match="drop grid"):
        ndrql.astar("room.yaml", start_world=(-7, 2), goal_world=(1.5, 4.5), octile=True, size=20)
    with pytest.raises(TypeError):
        ndrql.astar("room.yaml", (59, 20), (39, 190), True)  # octile and the rest are keywords


def test_print_path_and_grid_only_on_request(room, capsys):
    code, out, _ = cli(capsys, "astar", "room.yaml", "--start", "59,20", "--goal", "39,190", "--print-path")
    assert code == 0
    line = next(x for x in out.splitlines() if x.startswith("path (planning-grid row,col): "))
    cells = [tuple(map(int, c.split(","))) for c in line.split(": ")[1].split()]
    assert len(cells) >= 2 and all(abs(a[0] - b[0]) + abs(a[1] - b[1]) == 1 for a, b in zip(cells, cells[1:]))
    code, out, _ = cli(capsys, "astar", "room.yaml", "--start", "59,20", "--goal", "39,190", "--octile", "--print-path")
    assert code == 0 and "path (map pixels row,col): 59,20 " in out


def test_a_large_grid_gives_no_q_learning_warning(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Image.fromarray(np.full((300, 300), 255, np.uint8)).save(tmp_path / "open.png")
    code, out, err = cli(capsys, "astar", "open.png", "--start", "1,1", "--goal", "298,298", "--size", "300")
    assert code == 0 and "300x300 cells" in out
    assert "Q-learning" not in err and "minutes" not in err, err


@pytest.mark.parametrize("extra, needle", [
    (("--path-out", "p.yaml"), "needs a map with a resolution"),
    (("--octile", "--grid", "area"), "--octile searches the full map"),
    (("--path-spacing", "0.1"), "--path-spacing applies to --path-out"),
    (("--jsonl", "x.jsonl"), "for scenario batches"),
    (("--all",), "need --scen FILE"),
])
def test_bad_flags_are_one_line(tmp_path, capsys, monkeypatch, extra, needle):
    monkeypatch.chdir(tmp_path)
    Image.fromarray(np.full((40, 40), 255, np.uint8)).save(tmp_path / "m.png")
    code, out, err = cli(capsys, "astar", "m.png", "--start", "1,1", "--goal", "30,30", *extra)
    assert code == 2 and err.count("\n") == 1 and err.startswith("ndrql: error: ") and needle in err, err
    assert not (tmp_path / "p.yaml").exists() and not (tmp_path / "x.jsonl").exists()


def test_octile_batch_records_the_optimum(tmp_path, capsys, monkeypatch):
    """Every scenario with --octile: the record's ratio is 1 (A* finds the optimum the .scen states)."""
    monkeypatch.chdir(tmp_path)
    m = np.zeros((40, 40), dtype=bool)
    m[10:12, :30] = True
    m[25:27, 10:] = True
    rows = ["".join("@" if b else "." for b in row) for row in m]
    (tmp_path / "w.map").write_text("type octile\nheight 40\nwidth 40\nmap\n" + "\n".join(rows) + "\n")
    pairs = [((2, 2), (38, 38)), ((38, 2), (2, 38)), ((5, 35), (35, 5))]
    lines = ["version 1"] + [f"0\tw.map\t40\t40\t{s[1]}\t{s[0]}\t{g[1]}\t{g[0]}\t{astar8(m, s, g).cost:.3f}"
                             for s, g in pairs]
    (tmp_path / "w.map.scen").write_text("\n".join(lines) + "\n")
    code, out, err = cli(capsys, "astar", "w.map", "--scen", "w.map.scen", "--all", "--octile", "--jsonl", "o.jsonl")
    assert code == 0, err
    assert "shorter than the straight octile" not in err  # 3 decimals: within the file's rounding
    recs = [json.loads(x) for x in (tmp_path / "o.jsonl").read_text().splitlines()]
    assert [r["scenario"] for r in recs] == [0, 1, 2]
    for r in recs:
        assert r["method"] == r["ran"] == "A*-octile" and r["status"] == "ok" and r["success"]
        assert r["convergence_steps"] is None and r["episodes"] is None and r["expanded"] > 0
        assert r["ratio"] == pytest.approx(1.0, abs=1e-3)
    assert "scenarios: 3; success 3" in out


def test_json_to_stdout_keeps_stdout_pure(room, capsys):
    code, out, err = cli(capsys, "astar", "room.yaml", "--start", "59,20", "--goal", "39,190", "--json", "-")
    assert code == 0
    data = json.loads(out)  # nothing else on stdout: the summary went to stderr
    assert data["method"] == "A*" and "A* (4-connected)" in err and set(data["timings"]) >= {"map", "search", "output"}


def test_a_star_run_and_a_planned_run_are_one_family(room):
    """Both carry what a path's users read (PathRun): plan's writer takes either."""
    from ndrql.cli.plan_cmd import write_path
    from ndrql.pipeline.shortest import PathRun

    a = ndrql.astar("room.yaml", start=(59, 20), goal=(39, 190))
    p = ndrql.plan("room.yaml", start=(59, 20), goal=(39, 190), method="QL")
    assert isinstance(a, PathRun) and isinstance(p, PathRun)
    for run, name in ((a, "a.yaml"), (p, "p.yaml")):
        write_path(name, run, 0.0)
        assert len(yaml.safe_load((room / name).read_text())["poses"]) == len(run.poses)
