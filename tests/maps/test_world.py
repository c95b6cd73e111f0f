"""World coordinates of ROS maps: pixels <-> metres, poses with yaw, nav_msgs/Path output, end to end."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml
from PIL import Image

from ndrql.errors import PointError
from ndrql.maps.grid import GridMap
from ndrql.maps.world import (
    nav_path,
    parse_world_point,
    path_yaws,
    pixels_to_world,
    world_to_pixel,
    yaw_quaternion,
)

from helpers.cli import assert_one_line_error, run_cli


def test_pixel_world_round_trip_with_a_rotated_origin():
    gm = GridMap(np.zeros((40, 60), dtype=bool), resolution=0.1, origin=(2.0, -1.0, math.pi / 2))
    # the lower-left corner of pixel (39, 0) is the origin; its centre is half a pixel in along x and y of the map
    xy = pixels_to_world(gm, [(39, 0)])
    assert xy[0] == pytest.approx([2.0 - 0.05, -1.0 + 0.05])
    rng = np.random.default_rng(0)
    for _ in range(50):
        r, c = int(rng.integers(0, 40)), int(rng.integers(0, 60))
        x, y = pixels_to_world(gm, [(r, c)])[0]
        assert world_to_pixel(gm, x, y) == (r, c)
    with pytest.raises(PointError, match="off the map"):
        world_to_pixel(gm, 100.0, 100.0)
    assert pixels_to_world(GridMap(np.zeros((3, 3), bool)), [(0, 0)]) is None
    with pytest.raises(PointError, match="needs a map with a resolution"):
        world_to_pixel(GridMap(np.zeros((3, 3), bool)), 0.0, 0.0)


def test_yaws_quaternions_and_the_path_message():
    xy = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 2.0]])
    assert path_yaws(xy) == pytest.approx([0.0, math.pi / 2, math.pi / 2])
    assert path_yaws(xy, start_yaw=1.0, goal_yaw=-1.0) == pytest.approx([1.0, math.pi / 2, -1.0])
    qx, qy, qz, qw = yaw_quaternion(math.pi / 2)
    assert (qx, qy) == (0.0, 0.0) and qz == pytest.approx(math.sqrt(0.5)) and qw == pytest.approx(math.sqrt(0.5))
    msg = nav_path(np.column_stack([xy, path_yaws(xy)]))
    assert msg["header"]["frame_id"] == "map" and len(msg["poses"]) == 3
    pose = msg["poses"][1]
    assert pose["header"]["frame_id"] == "map" and pose["pose"]["position"] == {"x": 1.0, "y": 0.0, "z": 0.0}
    q = pose["pose"]["orientation"]
    assert math.isclose(q["x"] ** 2 + q["y"] ** 2 + q["z"] ** 2 + q["w"] ** 2, 1.0, abs_tol=1e-5)
    assert parse_world_point("1.5, -2") == (1.5, -2.0, None) and parse_world_point("0,0,3.14")[2] == 3.14
    for bad in ("1", "a,b", "1,2,3,4", "nan,1"):
        with pytest.raises(PointError):
            parse_world_point(bad)


def _ros_map(tmp_path) -> None:
    m = np.zeros((300, 400), dtype=bool)
    m[150:154, :320] = True  # a wall with an opening on the right
    gray = np.where(m, 0, 254).astype(np.uint8)
    Image.fromarray(gray).save(tmp_path / "floor.pgm")
    (tmp_path / "floor.yaml").write_text("image: floor.pgm\nresolution: 0.05\norigin: [-5.0, -2.0, 0.0]\nnegate: 0\n"
                                         "occupied_thresh: 0.65\nfree_thresh: 0.196\n", encoding="utf-8")


def test_ros_map_end_to_end_world_points_in_and_a_path_file_out(ndrql_exe, tmp_path):
    _ros_map(tmp_path)
    # start top-left, goal bottom-left (metres in the map frame: x = -5 + 0.05 (col + 0.5), y = -2 + 0.05 (300 - row - 0.5))
    start, goal = (-4.0, 10.0, 0.0), (-4.0, 0.0, math.pi)
    out = tmp_path / "plan.yaml"
    r = run_cli(ndrql_exe, "plan", str(tmp_path / "floor.yaml"), "--method", "QL",
                "--start-world=" + ",".join(map(str, start)), "--goal-world=" + ",".join(map(str, goal)),
                "--robot-radius", "0.1", "--path-out", str(out), "--json", str(tmp_path / "plan.json"))
    assert r.returncode == 0, r.stderr
    assert "robot radius 2 px = 0.10 m" in r.stdout and "collision-free" in r.stdout
    msg = yaml.safe_load(out.read_text())
    assert msg["header"]["frame_id"] == "map"
    first, last = msg["poses"][0]["pose"], msg["poses"][-1]["pose"]
    assert first["position"]["x"] == pytest.approx(start[0], abs=0.05) and first["position"]["y"] == pytest.approx(start[1], abs=0.05)
    assert last["position"]["x"] == pytest.approx(goal[0], abs=0.05) and last["position"]["y"] == pytest.approx(goal[1], abs=0.05)
    assert first["orientation"]["w"] == pytest.approx(1.0) and last["orientation"]["z"] == pytest.approx(1.0)
    assert max(p["pose"]["position"]["x"] for p in msg["poses"]) > -5 + 0.05 * 320  # round the wall's end
    data = json.loads((tmp_path / "plan.json").read_text())
    corners = data["runs"][0]["path_world"]  # the JSON keeps the route's corners; --path-out a pose per map cell
    assert data["runs"][0]["success"] and len(msg["poses"]) > len(corners) >= 2
    assert [round(v, 3) for v in corners[0][:2]] == [round(first["position"]["x"], 3), round(first["position"]["y"], 3)]
    gaps = [math.dist((a["pose"]["position"]["x"], a["pose"]["position"]["y"]), (b["pose"]["position"]["x"], b["pose"]["position"]["y"]))
            for a, b in zip(msg["poses"], msg["poses"][1:])]
    assert max(gaps) <= 0.05 * 1.01  # about one pose per map cell (0.05 m; poses are rounded to 0.1 mm)
    js = tmp_path / "plan.json.path"
    r = run_cli(ndrql_exe, "plan", str(tmp_path / "floor.yaml"), "--method", "QL", "--start", "40,20",
                "--goal", "260,20", "--path-out", str(js))
    assert r.returncode == 0 and json.loads(js.read_text())["header"]["frame_id"] == "map"


def test_world_points_and_path_file_need_a_ros_map(ndrql_exe, tmp_path):
    np.save(tmp_path / "m.npy", np.zeros((50, 50), dtype=bool))
    for extra in (["--start-world", "1,1", "--goal", "40,40"], ["--start", "1,1", "--goal", "40,40", "--path-out", "p.yaml"],
                  ["--start", "1,1", "--start-world", "1,1", "--goal", "40,40"]):
        r = run_cli(ndrql_exe, "plan", str(tmp_path / "m.npy"), "--method", "QL", *extra, cwd=tmp_path)
        assert_one_line_error(r)
        assert "resolution" in r.stderr or "not both" in r.stderr
