"""Thin walls survive everywhere: ``astar``, ``map info``, ``predict`` and ``GridPath-v0`` on a user's map
plan and draw on the grid ``plan`` builds (the safe rule, size auto, the robot's inflation) and name it.

The map is a hand-drawn ROS ``map_server`` apartment: 5 cm pixels, 2 px walls between hall and bath with
one door, a 2 px inner wall, and unknown space at the right. On the paper's 50x50 area grid a 2 px wall
is less than half of every cell it crosses, so the grid opens it and paths run through it (checked
below, so this test would notice if the map stopped being a trap).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from ndrql.cli import main as cli_main
from ndrql.env import GridPathEnv
from ndrql.maps.astar import astar4
from ndrql.maps.grid import cell_to_point
from ndrql.maps.lines import polyline_collisions
from ndrql.maps.readers import load_map
from ndrql.maps.safe import conservative_grid

START, GOAL = (10, 40), (20, 120)


@pytest.fixture(scope="module")
def apartment(tmp_path_factory):
    root = tmp_path_factory.mktemp("apartment")
    m = np.zeros((120, 160), dtype=bool)
    m[:, 78:80] = True
    m[90:104, 78:80] = False  # the one door between hall and bath, far below the points
    m[40:42, :60] = True  # an inner 2 px wall
    gray = np.where(m, 0, 254).astype(np.uint8)
    gray[:, 150:] = 205  # unknown
    Image.fromarray(gray).save(root / "apt.pgm")
    (root / "apt.yaml").write_text("image: apt.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
                                   "occupied_thresh: 0.65\nfree_thresh: 0.196\n", encoding="utf-8")
    return root / "apt.yaml"


def _cli(capsys, *argv) -> str:
    code = cli_main([str(a) for a in argv])
    out = capsys.readouterr()
    assert code == 0, out.err
    return out.out


def _centres(rows_cols, cell: float) -> np.ndarray:
    return np.asarray([((r + 0.5) * cell - 0.5, (c + 0.5) * cell - 0.5) for r, c in rows_cols], dtype=float)


def test_astar_keeps_the_wall_and_names_the_grid(apartment, tmp_path, capsys):
    obstacles = load_map(apartment).obstacles
    out = _cli(capsys, "astar", apartment, "--start", "10,40", "--goal", "20,120", "--json", tmp_path / "a.json",
               "--png", tmp_path / "a.png")
    data = json.loads((tmp_path / "a.json").read_text())
    assert "planning grid: safe" in out and data["planning_grid"]["rule"] == "safe" and "auto" in data["planning_grid"]
    assert data["collisions"] == [] and not polyline_collisions(obstacles, np.asarray(data["path_pixels"]))
    assert max(r for r, _ in data["path_pixels"]) >= 90  # through the door, the only way
    # the paper's area grid opens the 2 px wall: the same command on it goes through the wall, and says so
    out = _cli(capsys, "astar", apartment, "--start", "10,40", "--goal", "20,120", "--grid", "area", "--size", "50",
               "--json", tmp_path / "b.json")
    area = json.loads((tmp_path / "b.json").read_text())
    assert "planning grid: area" in out and area["collisions"] and "crosses obstacles" in out


def test_map_info_shows_plans_grid(apartment, tmp_path, capsys):
    obstacles = load_map(apartment).obstacles
    _cli(capsys, "astar", apartment, "--start", "10,40", "--goal", "20,120", "--json", tmp_path / "a.json")
    astar = json.loads((tmp_path / "a.json").read_text())
    out = _cli(capsys, "map", "info", apartment, "--start", "10,40", "--goal", "20,120", "--json", tmp_path / "i.json")
    info = json.loads((tmp_path / "i.json").read_text())
    assert "planning grid: safe" in out and info["grid"] == astar["grid"]
    size = info["planning_grid"]["size"]
    expected = ["".join("#" if b else "." for b in row) for row in conservative_grid(obstacles, size)]
    assert info["grid"] == expected
    out = _cli(capsys, "map", "info", apartment, "--json", tmp_path / "j.json")  # no points: safe at 50
    plain = json.loads((tmp_path / "j.json").read_text())
    assert "planning grid: safe" in out and plain["grid_rule"] == "safe"
    assert plain["grid"] == ["".join("#" if b else "." for b in row) for row in conservative_grid(obstacles, 50)]


def test_predict_sees_plans_grid(apartment, tmp_path, capsys):
    _cli(capsys, "astar", apartment, "--start", "10,40", "--goal", "20,120", "--robot-radius", "0.05",
         "--json", tmp_path / "a.json")
    astar = json.loads((tmp_path / "a.json").read_text())
    out = _cli(capsys, "predict", apartment, "--start", "10,40", "--goal", "20,120", "--robot-radius", "0.05",
               "--out", tmp_path / "pred")
    assert "planning grid: safe" in out and "robot radius 1.0 px" in out
    with np.load(tmp_path / "pred" / "prediction.npz") as z:
        if "grid_blocked" in z.files:  # a grid-mode model (the default general weights)
            rows = ["".join("#" if b else "." for b in row) for row in z["grid_blocked"]]
            assert rows == astar["grid"]


def test_gridpath_env_from_a_map_file_keeps_the_wall(apartment):
    obstacles = load_map(apartment).obstacles
    env = GridPathEnv(map=str(apartment), start=START, goal=GOAL)
    assert env.grid_rule == "safe" and isinstance(env.size, int)
    assert np.array_equal(env.blocked, conservative_grid(obstacles, env.size))
    path = astar4(env.blocked, env.start, env.goal).path
    cell = max(obstacles.shape) / env.size
    assert not polyline_collisions(obstacles, _centres(path, cell))
    env.reset(options={"start": (15, 45)})  # new points on the same map keep the size auto chose
    assert env.blocked.shape == conservative_grid(obstacles, env.size).shape
    area = GridPathEnv(map=str(apartment), start=START, goal=GOAL, grid_rule="area")  # the paper's grid opens it
    through = astar4(area.blocked, area.start, area.goal).path
    assert polyline_collisions(obstacles, [cell_to_point(c, obstacles.shape, area.blocked.shape) for c in through])
