"""Bad input to ``ndrql plan`` / ``ndrql demo``: one clear line on stderr and exit code 2 (real console script)."""

from __future__ import annotations

import os

import numpy as np
import pytest

from helpers.cli import assert_one_line_error, run_cli


@pytest.fixture
def walls(tmp_path):
    """100x100 map: obstacle block at rows 10..19, cols 10..19; a full wall at rows 60..69 cuts it in two."""
    m = np.zeros((100, 100), dtype=bool)
    m[10:20, 10:20] = True
    m[60:70, :] = True
    path = tmp_path / "walls.npy"
    np.save(path, m)
    return path


@pytest.mark.parametrize(
    "points,needle",
    [
        (("15,15", "50,50"), "start 15,15 is on an obstacle of the map"),
        (("0,0", "12,18"), "goal 12,18 is on an obstacle of the map"),
        (("-1,5", "50,50"), "start -1,5 is outside the map (rows 0..99, cols 0..99)"),
        (("0,0", "50,100"), "goal 50,100 is outside the map"),
        (("0,0", "99,99"), "are not connected on the map itself"),  # the wall separates them
        (("0,0", "five,5"), "--goal must be ROW,COL"),
    ],
)
def test_bad_points(ndrql_exe, walls, points, needle):
    r = run_cli(ndrql_exe, "plan", walls, f"--start={points[0]}", f"--goal={points[1]}", "--method", "QL")
    assert_one_line_error(r, needle)


@pytest.mark.parametrize("grid", ["safe", "area"])
def test_same_planning_cell(ndrql_exe, walls, grid):
    r = run_cli(ndrql_exe, "plan", walls, "--start", "0,0", "--goal", "1,1", "--method", "QL", "--grid", grid,
                "--size", "10")
    assert_one_line_error(r, "same planning cell")


def test_unsupported_file(ndrql_exe, tmp_path):
    f = tmp_path / "notes.txt"
    f.write_text("not a map\n")
    r = run_cli(ndrql_exe, "plan", f, "--start", "0,0", "--goal", "1,1")
    assert_one_line_error(r, "unsupported map format '.txt'")


def test_missing_map_file(ndrql_exe, tmp_path):
    r = run_cli(ndrql_exe, "plan", tmp_path / "nope.png", "--start", "0,0", "--goal", "1,1")
    assert_one_line_error(r, "map file not found")


def test_map_too_large(ndrql_exe, tmp_path):
    big = np.zeros((4097, 4097), dtype=bool)  # one pixel row and column over the default 4096 x 4096 limit
    np.save(tmp_path / "big.npy", big)
    r = run_cli(ndrql_exe, "plan", tmp_path / "big.npy", "--start", "0,0", "--goal", "4000,4000", "--method", "QL")
    assert_one_line_error(r, "map is 4097x4097 = 16,785,409 pixels, more than the limit of 16,777,216")
    assert "--max-pixels" in r.stderr


def test_map_too_large_for_given_limit_and_grid_too_fine(ndrql_exe, walls):
    r = run_cli(ndrql_exe, "plan", walls, "--start", "0,0", "--goal", "50,50", "--max-pixels", "5000")
    assert_one_line_error(r, "more than the limit of 5,000")
    r = run_cli(ndrql_exe, "plan", walls, "--start", "0,0", "--goal", "50,50", "--size", "1000")
    assert_one_line_error(r, "planning grid size 1000 is larger than the limit 512")


def test_missing_model_weights(ndrql_exe, walls):
    env = {**os.environ, "NDRQL_WEIGHTS": "/nonexistent/ndr.pt"}
    r = run_cli(ndrql_exe, "plan", walls, "--start", "0,0", "--goal", "50,50", "--prior-from", "model", env=env)
    assert_one_line_error(r, "missing model weights: /nonexistent/ndr.pt")
    # methods without the model, and NDR-QL on a known map (the exact prior by default), do not need weights
    r = run_cli(ndrql_exe, "plan", walls, "--start", "0,0", "--goal", "50,50", "--method", "IQL", env=env)
    assert r.returncode == 0 and "IQL seed 0: converged" in r.stdout, r.stderr
    r = run_cli(ndrql_exe, "plan", walls, "--start", "0,0", "--goal", "50,50", env=env)
    assert r.returncode == 0 and "prediction: exact accepted" in r.stdout, r.stderr


def test_corrupt_weights(ndrql_exe, walls, tmp_path):
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a checkpoint")
    assert_one_line_error(run_cli(ndrql_exe, "plan", walls, "--start", "0,0", "--goal", "50,50", "--weights", bad),
                          "cannot read checkpoint")


def test_scenario_errors(ndrql_exe, tmp_path):
    (tmp_path / "a.map").write_text("type octile\nheight 4\nwidth 4\nmap\n....\n....\n....\n....\n", encoding="ascii")
    (tmp_path / "a.scen").write_text("version 1\n0\ta.map\t4\t4\t0\t0\t3\t3\t4.24\n", encoding="ascii")
    r = run_cli(ndrql_exe, "plan", tmp_path / "a.map", "--scen", tmp_path / "a.scen", "--index", "5", "--method", "QL")
    assert_one_line_error(r, "scenario 5 not in")
    (tmp_path / "b.scen").write_text("version 1\n0\ta.map\t8\t8\t0\t0\t3\t3\t4.24\n", encoding="ascii")
    r = run_cli(ndrql_exe, "plan", tmp_path / "a.map", "--scen", tmp_path / "b.scen", "--method", "QL")
    assert_one_line_error(r, "is for a 8x8 map")
    r = run_cli(ndrql_exe, "plan", tmp_path / "a.map", "--index", "1", "--method", "QL")
    assert_one_line_error(r, "--index needs --scen FILE")


def test_missing_points(ndrql_exe, walls):
    assert_one_line_error(run_cli(ndrql_exe, "plan", walls, "--start", "0,0"), "--goal required with a map file")


def test_bad_threads(ndrql_exe, walls):
    assert_one_line_error(run_cli(ndrql_exe, "plan", walls, "--start", "0,0", "--goal", "50,50", "--threads", "0"),
                          "--threads must be an integer in 1..")
