"""A pip user's first minutes, through the real console script: the bundled example from any folder,
world points typed as users type them, a path a controller can follow, help that points online, and
one line when the first run compiles."""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from PIL import Image

from helpers.cli import assert_one_line_error, run_cli
from ndrql.cli import join_negative_values
from ndrql.version import DOCS_URL


def test_plan_astar_and_map_info_take_the_bundled_example_from_an_empty_folder(ndrql_exe, model_weights, tmp_path):
    r = run_cli(ndrql_exe, "plan", "--example", "--method", "QL", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    said = [line for line in r.stderr.splitlines() if "example map" in line]
    assert len(said) == 1 and "start 25,179, goal 167,5" in said[0], r.stderr
    installed = Path(re.search(r"example map (\S+) \(201x201\)", said[0]).group(1))
    assert installed.is_file() and installed.name == "sample_map.png"
    assert "QL seed 0: converged" in r.stdout and "collision-free" in r.stdout
    a = run_cli(ndrql_exe, "astar", "--example", cwd=tmp_path)
    assert a.returncode == 0 and "A* (4-connected)" in a.stdout, a.stderr
    m = run_cli(ndrql_exe, "map", "info", "--example", cwd=tmp_path)
    assert m.returncode == 0 and "201 rows x 201 cols" in m.stdout, m.stderr
    # the recorded points can be overridden, and the map cannot be given twice
    o = run_cli(ndrql_exe, "astar", "--example", "--goal", "100,100", cwd=tmp_path)
    assert o.returncode == 0 and "goal 100,100" not in o.stderr
    assert_one_line_error(run_cli(ndrql_exe, "plan", "--example", "map.png", cwd=tmp_path), "give one of MAP")


def _ros_map(tmp_path: Path) -> Path:
    """A 10 x 6 m room at 0.05 m per pixel whose origin puts most of it at negative x: a wall with a door."""
    img = np.full((120, 200), 254, np.uint8)
    img[:, 100:103] = 0
    img[50:70, 100:103] = 254  # a 1 m door
    Image.fromarray(img).save(tmp_path / "room.pgm")
    (tmp_path / "room.yaml").write_text("image: room.pgm\nresolution: 0.05\norigin: [-8.0, -1.0, 0.0]\n"
                                        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return tmp_path / "room.yaml"


def test_world_points_take_negative_numbers_as_typed_and_the_path_has_a_pose_per_cell(ndrql_exe, tmp_path):
    yml = _ros_map(tmp_path)
    out = tmp_path / "path.yaml"
    r = run_cli(ndrql_exe, "plan", yml, "--start-world", "-7.5,4.0", "--goal-world", "1.5,-0.5,1.57", "--method", "QL",
                "--path-out", out, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    poses = yaml.safe_load(out.read_text())["poses"]
    xy = [(p["pose"]["position"]["x"], p["pose"]["position"]["y"]) for p in poses]
    gaps = [math.dist(a, b) for a, b in zip(xy, xy[1:])]
    assert max(gaps) <= 0.05 + 1e-3 and len(poses) > 100  # about one pose per 5 cm map cell
    assert xy[0] == pytest.approx((-7.5, 4.0), abs=0.05) and xy[-1] == pytest.approx((1.5, -0.5), abs=0.05)
    assert poses[-1]["pose"]["orientation"]["z"] == pytest.approx(math.sin(1.57 / 2), abs=1e-4)
    corners = run_cli(ndrql_exe, "plan", yml, "--start-world", "-7.5,4.0", "--goal-world", "1.5,-0.5", "--method", "QL",
                      "--path-out", tmp_path / "corners.json", "--path-spacing", "0", cwd=tmp_path)
    assert corners.returncode == 0, corners.stderr
    import json

    few = json.loads((tmp_path / "corners.json").read_text())["poses"]
    assert 2 <= len(few) < len(poses) / 10
    bad = run_cli(ndrql_exe, "plan", yml, "--start-world", "-7.5,4.0", "--goal-world", "1.5,-0.5", "--method", "QL",
                  "--path-out", tmp_path / "x.yaml", "--path-spacing", "-1", cwd=tmp_path)
    assert_one_line_error(bad, "--path-spacing")
    assert not (tmp_path / "x.yaml").exists()


def test_join_negative_values():
    assert join_negative_values(["plan", "m.yaml", "--start-world", "-1.925,4.625", "--goal-world", "-3,-2,0.5"]) == [
        "plan", "m.yaml", "--start-world=-1.925,4.625", "--goal-world=-3,-2,0.5"]
    # plain negative numbers, lists after a value or after a flag written with = are left to argparse
    assert join_negative_values(["--seed", "-1", "--x=1", "-2,3", "a", "-2,3"]) == ["--seed", "-1", "--x=1", "-2,3", "a", "-2,3"]


@pytest.mark.parametrize("command", ["plan", "astar", "predict", "demo", "map", "eval", "train", "reproduce", "tune"])
def test_help_points_to_the_docs_online_not_to_a_folder_a_pip_install_lacks(ndrql_exe, command):
    r = run_cli(ndrql_exe, command, "--help")
    assert r.returncode == 0, r.stderr
    text = r.stdout.replace(DOCS_URL, "")
    assert not re.search(r"(?<![\w/.])docs/", text), [line for line in r.stdout.splitlines() if "docs/" in line]
    assert "%%" not in r.stdout


@pytest.mark.slow
def test_the_first_run_says_once_that_it_compiles(ndrql_exe, model_weights, tmp_path):
    """numba's kernels (the fallback when the C extension is not built) compile on the first run and say so."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "NDRQL_KERNELS": "numba"}
    first = run_cli(ndrql_exe, "plan", "--example", "--method", "QL", cwd=tmp_path, env=env)
    assert first.returncode == 0, first.stderr
    notice = [line for line in first.stderr.splitlines() if "compiling" in line]
    assert len(notice) == 1 and str(tmp_path / "numba") in notice[0], first.stderr
    second = run_cli(ndrql_exe, "plan", "--example", "--method", "QL", cwd=tmp_path, env=env)
    assert second.returncode == 0 and "compiling" not in second.stderr, second.stderr


def test_with_the_c_kernels_the_first_run_compiles_nothing_and_loads_neither_numba_nor_scipy(model_weights, tmp_path):
    """The C extension built at install time: an empty numba cache, yet no notice, and no numba, llvmlite or
    scipy in the process (their imports are most of a warm plan's start-up)."""
    from ndrql.maps import native

    if native.extension() is None:
        pytest.skip("the C extension ndrql.maps._kernels is not built (no C compiler at install time)")
    code = ("import sys, json; from ndrql.cli import main; rc = main(['plan', '--example', '--json', 'out.json']); "
            "print(json.dumps([rc, sorted({m.split('.')[0] for m in sys.modules} & {'numba', 'llvmlite', 'scipy'}), "
            "json.load(open('out.json'))['kernels']]))")
    src = str(Path(native.__file__).resolve().parents[2])  # this ndrql, whatever the working folder
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "NDRQL_KERNELS": "auto",
           "PYTHONPATH": os.pathsep.join([src, os.environ.get("PYTHONPATH", "")])}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout.splitlines()[-1]) == [0, [], "c"]
    assert "compiling" not in r.stderr and not (tmp_path / "numba").exists()


def test_geometric_ci_of_steps_never_goes_below_zero():
    from ndrql.planning.results import geometric_ci, summarize

    assert summarize([1, 1_000_000])["ci95_low"] < 0  # the arithmetic interval of two skewed counts does
    low, high = geometric_ci([1, 1_000_000])
    assert 0 < low < 1_000 < high
    assert geometric_ci([400, 400]) == pytest.approx((400, 400))
    assert geometric_ci([5]) is None and geometric_ci([None, 0, 7]) is None


@pytest.mark.slow
def test_demo_plans_as_plan_does_without_collisions_and_with_plans_default_priors(ndrql_exe, model_weights, tmp_path):
    r = run_cli(ndrql_exe, "demo", "--seeds", "2", "--out", tmp_path / "demo", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    # the sample map is a map file the planner fully knows: plan's default policy, the exact prior, accepted
    assert "prediction: exact accepted (Eq. 7 threshold" in r.stdout and "fell back" not in r.stdout
    for m in ("QL", "IQL", "NDR-QL"):
        assert f"{m}: 2 of 2 paths collision-free" in r.stdout, r.stdout
    rows = {line.split()[0]: line for line in r.stdout.splitlines() if re.match(r"(QL|IQL|NDR-QL) +2/2 ", line)}
    for line in rows.values():
        low = re.search(r"\[([\d,]+), ([\d,]+)\]", line)
        assert low and int(low.group(1).replace(",", "")) > 0, line
    table = (tmp_path / "demo" / "table.md").read_text()
    for m in ("QL", "IQL", "NDR-QL"):
        ci = next(line for line in table.splitlines() if line.startswith(f"| {m} |")).split("|")[5]
        low, high = (int(v.replace(",", "")) for v in ci.split(" - "))
        assert 0 < low <= high, ci
