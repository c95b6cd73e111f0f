"""The real ``ndrql`` console script: astar, map, demo, and one clear error line for bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from ndrql.maps import bfs_distances, path_is_valid, planning_grid

from helpers.cli import assert_one_line_error, run_cli


@pytest.fixture()
def room_png(tmp_path):
    """A 120x80 (non-square) map: a wall with a gap, as a PNG (black = obstacle)."""
    obstacles = np.zeros((120, 80), dtype=bool)
    obstacles[58:64, :60] = True
    img = np.where(obstacles, 0, 255).astype(np.uint8)
    path = tmp_path / "room.png"
    Image.fromarray(img).save(path)
    return path, obstacles


def test_help_lists_the_foundation_subcommands(ndrql_exe):
    r = run_cli(ndrql_exe, "--help")
    assert r.returncode == 0 and r.stderr == ""
    for name in ("demo", "map", "astar"):
        assert name in r.stdout
    r = run_cli(ndrql_exe, "astar", "--help")
    assert r.returncode == 0 and "--sample" in r.stdout and "examples:" in r.stdout


def test_astar_on_a_png_writes_json_and_png(ndrql_exe, room_png, tmp_path):
    path, obstacles = room_png
    r = run_cli(ndrql_exe, "astar", path, "--start", "5,5", "--goal", "115,10", "--json", tmp_path / "o" / "r.json",
                "--png", tmp_path / "o" / "r.png", "--grid", "area", "--size", "50")  # the paper's grid: known answers
    assert r.returncode == 0, r.stderr
    data = json.loads((tmp_path / "o" / "r.json").read_text())
    blocked = planning_grid(obstacles)
    assert data["grid"] == ["".join("#" if b else "." for b in row) for row in blocked]
    # cell containing the pixel centre: row (2r+1)*50 // (2*120), col (2c+1)*50 // (2*80)
    assert data["start"] == [2, 3] and data["goal"] == [48, 6]
    path_cells = [tuple(c) for c in data["path"]]
    assert path_cells[0] == tuple(data["start"]) and path_cells[-1] == tuple(data["goal"])
    assert path_is_valid(blocked, path_cells)
    assert data["length"] == len(path_cells) - 1 == bfs_distances(blocked, (2, 3))[48, 6]
    assert data["map"]["height"] == 120 and data["map"]["width"] == 80
    assert f"{data['length']} moves" in r.stdout and "planning grid: area" in r.stdout
    assert (tmp_path / "o" / "r.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_astar_print_grid_and_snap_warning(ndrql_exe, room_png):
    path, _ = room_png
    # pixel (64, 10) is free, its planning cell (26, 6) two-thirds wall: snapped with a warning
    r = run_cli(ndrql_exe, "astar", path, "--start", "64,10", "--goal", "115,10", "--print-grid", "--grid", "area")
    assert r.returncode == 0
    assert r.stderr.startswith("ndrql: warning: start (64, 10) falls in blocked planning cell (26, 6)")
    # a start on an obstacle pixel is refused, as by plan
    refused = run_cli(ndrql_exe, "astar", path, "--start", "60,10", "--goal", "115,10")
    assert refused.returncode == 2 and refused.stderr == "ndrql: error: start 60,10 is on an obstacle of the map\n"
    grid_lines = [ln for ln in r.stdout.splitlines() if len(ln) == 50 and set(ln) <= set("#.*SG")]
    assert len(grid_lines) == 50 and sum(ln.count("S") for ln in grid_lines) == 1


@pytest.mark.data
def test_astar_on_a_dataset_sample(ndrql_exe, dataset_root, tmp_path):
    from ndrql.dataset.layout import load_sample
    from ndrql.maps import PlanningGrid, astar4

    r = run_cli(ndrql_exe, "astar", "--sample", f"{dataset_root}:seen:0", "--json", tmp_path / "s.json",
                "--png", tmp_path / "s.png", "--print-path")
    assert r.returncode == 0, r.stderr
    data = json.loads((tmp_path / "s.json").read_text())
    sample = load_sample(dataset_root, "seen", 0)
    pg = PlanningGrid.from_map(sample.map, sample.start, sample.goal)
    assert data["source_start"] == list(sample.start) and data["source_goal"] == list(sample.goal)
    assert data["start"] == list(pg.start) and data["goal"] == list(pg.goal)
    cells = [tuple(c) for c in data["path"]]
    assert cells[0] == pg.start and cells[-1] == pg.goal and path_is_valid(pg.blocked, cells)
    assert data["length"] == astar4(pg.blocked, pg.start, pg.goal).moves == bfs_distances(pg.blocked, pg.start)[pg.goal]
    assert data["sample"]["category"] == "GAPS"
    printed = next(ln for ln in r.stdout.splitlines() if ln.startswith("path (planning-grid row,col): "))
    assert [tuple(map(int, p.split(","))) for p in printed.split(": ")[1].split()] == cells
    assert (tmp_path / "s.png").stat().st_size > 1000


def test_map_info_and_convert(ndrql_exe, room_png, tmp_path):
    path, obstacles = room_png
    r = run_cli(ndrql_exe, "map", "info", path, "--json", tmp_path / "i.json", "--grid", "area")
    assert r.returncode == 0, r.stderr
    assert "planning grid: area" in r.stdout
    assert "120 rows x 80 cols" in r.stdout and f"{100 * obstacles.mean():.2f}%" in r.stdout
    assert sum(1 for ln in r.stdout.splitlines() if len(ln) == 50 and set(ln) <= set("#.")) == 50
    assert json.loads((tmp_path / "i.json").read_text())["obstacle_ratio"] == pytest.approx(obstacles.mean())
    r = run_cli(ndrql_exe, "map", "convert", path, tmp_path / "r.npy")
    assert r.returncode == 0, r.stderr
    np.testing.assert_array_equal(np.load(tmp_path / "r.npy"), obstacles)


def test_astar_octile_movingai_scenario(ndrql_exe, tmp_path):
    (tmp_path / "w.map").write_text("type octile\nheight 3\nwidth 5\nmap\n.....\n@@@@.\n.....\n")
    (tmp_path / "w.scen").write_text("version 1\n0\tw.map\t5\t3\t0\t0\t0\t2\t10.00000000\n")
    r = run_cli(ndrql_exe, "astar", tmp_path / "w.map", "--scen", f"{tmp_path / 'w.scen'}:0", "--octile",
                "--json", tmp_path / "w.json")
    assert r.returncode == 0, r.stderr
    data = json.loads((tmp_path / "w.json").read_text())
    assert data["length"] == pytest.approx(10.0) and data["scenario"]["optimal_length"] == pytest.approx(10.0)
    assert data["start"] == [0, 0] and data["goal"] == [2, 0]


def test_scen_argument_parses_one_way(tmp_path):
    """``--scen FILE[:K]`` for astar and plan: a trailing integer is K unless FILE:K is itself a file."""
    from ndrql.cli.common import parse_scen

    assert parse_scen("a.scen") == ("a.scen", None)
    assert parse_scen("dir:x/a.scen:3") == ("dir:x/a.scen", 3)
    assert parse_scen("a.scen:-1") == ("a.scen", -1)
    assert parse_scen("a.scen:x") == ("a.scen:x", None)
    assert parse_scen("a.scen:" + "9" * 13) == ("a.scen:" + "9" * 13, None)
    odd = tmp_path / "odd.scen:2"
    odd.write_text("version 1\n")
    assert parse_scen(str(odd)) == (str(odd), None)


@pytest.mark.slow
def test_demo_writes_png_and_json(ndrql_exe, tmp_path, model_weights):
    r = run_cli(ndrql_exe, "demo", "--out", tmp_path / "demo", "--seeds", "2")
    assert r.returncode == 0, r.stderr
    data = json.loads((tmp_path / "demo" / "results.json").read_text())
    assert data["methods"] == ["QL", "IQL", "NDR-QL"] and len(data["runs"]) == 6
    assert (tmp_path / "demo" / "compare.png").exists()


# ------------------------------------------------------------------ bad input: one line, exit 2


def test_error_missing_file(ndrql_exe, tmp_path):
    r = run_cli(ndrql_exe, "astar", tmp_path / "nope.png", "--start", "0,0", "--goal", "1,1")
    assert_one_line_error(r, "not found")


def test_error_corrupt_image(ndrql_exe, tmp_path):
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)))
    assert_one_line_error(run_cli(ndrql_exe, "map", "info", bad), "cannot read image")


def test_error_yaml_missing_keys(ndrql_exe, tmp_path):
    Image.fromarray(np.full((4, 4), 254, np.uint8)).save(tmp_path / "m.pgm")
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.05\n")
    r = run_cli(ndrql_exe, "map", "info", tmp_path / "m.yaml")
    assert_one_line_error(r, "missing key(s) origin, occupied_thresh, free_thresh")


def test_error_bad_movingai_header(ndrql_exe, tmp_path):
    (tmp_path / "b.map").write_text("type octile\nheight x\nwidth 4\nmap\n....\n")
    r = run_cli(ndrql_exe, "astar", tmp_path / "b.map", "--start", "0,0", "--goal", "0,3")
    assert_one_line_error(r, "bad header")


@pytest.mark.parametrize("start, goal, match", [("120,5", "5,5", "start 120,5 is outside the map"), ("5,5", "5,-1", "goal 5,-1 is outside the map")])
def test_error_point_off_the_map(ndrql_exe, room_png, start, goal, match):
    path, _ = room_png
    assert_one_line_error(run_cli(ndrql_exe, "astar", path, "--start", start, "--goal", goal), match)


def test_error_no_path(ndrql_exe, tmp_path):
    obstacles = np.zeros((40, 40), dtype=bool)
    obstacles[18:22, :] = True
    np.save(tmp_path / "wall.npy", obstacles)
    r = run_cli(ndrql_exe, "astar", tmp_path / "wall.npy", "--start", "2,2", "--goal", "38,38")
    assert_one_line_error(r, "not connected on the map itself")


@pytest.mark.parametrize(
    "args, match",
    [
        (["astar", "MAP", "--start", "1;2", "--goal", "3,4"], "--start must be ROW,COL"),
        (["astar", "MAP", "--goal", "3,4"], "--start required"),
        (["astar", "--sample", "/no/such/dir:seen:0"], "dataset directory not found"),
        (["astar", "--sample", "/tmp:test:0"], "unknown split 'test'"),
        (["astar"], "no map given"),
        (["map", "info", "notes.txt"], "unsupported map format '.txt'"),
    ],
)
def test_error_bad_arguments(ndrql_exe, room_png, args, match):
    path, _ = room_png
    args = [str(path) if a == "MAP" else a for a in args]
    assert_one_line_error(run_cli(ndrql_exe, *args), match)
