"""The second hostile campaign's cases through the real console script: bounded runs, no traceback,
one meaning per pixel, messages that help (issue: "never lose what the user has").

Each refusal is exit code 2 and exactly one ``ndrql: error:`` line; the memory cases run under a 1 GB
address-space cap (``RLIMIT_AS``) in the child, so a regression is "out of memory", not a swapping machine.
"""

from __future__ import annotations

import os
import pickle
import resource
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from helpers.cli import assert_one_line_error, run_cli

GB = 1 << 30
POINTS = ("--start", "1,1", "--goal", "90,100")


def capped(limit: int = GB):
    def apply() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    return apply


def run(exe, cwd: Path, *args: str, cap: bool = False, **kw) -> subprocess.CompletedProcess:
    env = {**os.environ, "NDRQL_CACHE": str(cwd / ".cache")}
    return run_cli(exe, *args, cwd=cwd, env=env, preexec_fn=capped() if cap else None, **kw)


@pytest.fixture()
def work(tmp_path: Path) -> Path:
    arr = np.full((100, 120), 255, np.uint8)
    arr[40:60, 50:70] = 0
    Image.fromarray(arr).save(tmp_path / "block.png")
    return tmp_path


# --- crashes, hangs and memory --------------------------------------------------------------------


@pytest.mark.parametrize("args", [("plan", "block.png", *POINTS, "--threads", "1000000"),
                                  ("plan", "block.png", *POINTS, "--threads", "5000"),
                                  ("predict", "block.png", *POINTS, "--threads", "1024")])
def test_threads_beyond_the_cores_are_one_line(ndrql_exe, work, args):
    assert_one_line_error(run(ndrql_exe, work, *args), "CPU cores" if args[0] == "plan" else "--threads")


def test_a_huge_episode_cap_runs_in_little_memory(ndrql_exe, work):
    r = run(ndrql_exe, work, "plan", "block.png", *POINTS, "--method", "QL", "--max-episodes", "10000000", cap=True)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "converged after" in r.stdout
    r = run(ndrql_exe, work, "plan", "block.png", *POINTS, "--method", "QL", "--max-episodes", "10000000", "--window",
            "1000000000", "--size", "8", cap=True)  # never converges: all 10^7 episodes' records, still under the cap
    assert r.returncode == 0 and "NOT converged in 10,000,000 episodes" in r.stdout, r.stderr[-2000:]
    assert_one_line_error(run(ndrql_exe, work, "plan", "block.png", *POINTS, "--method", "QL", "--max-episodes",
                              "100000000"), "--max-episodes must be an integer in 1..10,000,000")


def test_a_big_ros_yaml_is_refused_before_parsing(ndrql_exe, work):
    (work / "big.yaml").write_text("image: block.png\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
                                   "free_thresh: 0.196\nnotes: [" + "1, " * 1_700_000 + "1]\n")
    assert_one_line_error(run(ndrql_exe, work, "map", "info", "big.yaml", cap=True), "more than the limit")


def test_a_thin_png_is_refused_from_its_header(ndrql_exe, work):
    Image.fromarray(np.full((1, 16_777_216), 255, np.uint8)).save(work / "thin.png")
    assert_one_line_error(run(ndrql_exe, work, "plan", "thin.png", "--start", "0,1", "--goal", "0,900", cap=True),
                          "too thin")


# --- no traceback -----------------------------------------------------------------------------------


def test_ctrl_c_is_interrupted_130_and_leaves_no_output(ndrql_exe, work):
    arr = np.full((300, 300), 255, np.uint8)
    arr[100:200:20, 20:280] = 0
    Image.fromarray(arr).save(work / "maze.png")
    env = {**os.environ, "NDRQL_CACHE": str(work / ".cache")}
    args = [*ndrql_exe, "plan", "maze.png", "--start", "1,1", "--goal", "298,298", "--method", "QL", "--size", "150",
            "--window", "1000000000", "--max-episodes", "10000000", "--json", "out.json"]
    proc = subprocess.Popen(args, cwd=work, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        time.sleep(15)  # start-up, map, grid, then Q-learning that never converges: interrupted wherever it is
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:  # never leave the run behind when the test fails
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, err[-2000:]
    assert err.strip().splitlines()[-1] == "ndrql: interrupted" and "Traceback" not in err
    assert not (work / "out.json").exists()


def test_stdout_full_or_closed_is_one_line(ndrql_exe, work):
    with open("/dev/full", "w") as full:
        r = subprocess.run([*ndrql_exe, "astar", "block.png", *POINTS], cwd=work, stdout=full, stderr=subprocess.PIPE,
                           text=True)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "No space left" in r.stderr, r.stderr
    r = subprocess.run([*ndrql_exe, "astar", "block.png", *POINTS, "--json", "-"], cwd=work, stdout=subprocess.DEVNULL,
                       stderr=subprocess.PIPE, text=True, preexec_fn=lambda: os.close(1))
    assert r.returncode == 2 and "standard output is closed" in r.stderr and r.stderr.count("\n") == 1, r.stderr


def test_bad_storage_url_and_deep_preset_are_one_line(ndrql_exe, work):
    assert_one_line_error(run(ndrql_exe, work, "tune", "--method", "IQL", "--storage", "bogus://x"), "--storage")
    (work / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    assert_one_line_error(run(ndrql_exe, work, "plan", "block.png", *POINTS, "--preset", "deep.json"), "nested too deeply")


def test_an_onnx_graph_with_a_fixed_input_is_one_line(ndrql_exe, work):
    onnx = pytest.importorskip("onnx")
    shipped = Path(__file__).resolve().parents[2] / "src" / "ndrql" / "data" / "ndr_default.onnx"
    if not shipped.is_file():
        pytest.skip("no shipped graph")
    model = onnx.load(str(shipped))
    for dim, value in zip(model.graph.input[0].type.tensor_type.shape.dim, (1, 3, 64, 64)):
        dim.ClearField("dim_param")
        dim.dim_value = value
    onnx.save(model, str(work / "fixed.onnx"))
    assert_one_line_error(run(ndrql_exe, work, "plan", "block.png", *POINTS, "--weights", "fixed.onnx"),
                          "not a graph ndrql can run")


def test_a_truncated_shard_names_the_file_and_the_fix(ndrql_exe, work):
    r = run(ndrql_exe, work, "data", "generate", "--family", "blocks", "--count", "4", "--size", "64", "--out", "gen",
            "--no-progress")
    assert r.returncode == 0, r.stderr
    shard = work / "gen" / "shard-00000.npz"
    data = shard.read_bytes()
    shard.write_bytes(data[: len(data) // 2])
    line = assert_one_line_error(run(ndrql_exe, work, "data", "show", "gen", "--png", "s.png"), "shard-00000.npz")
    assert "ndrql data generate" in line
    (work / "gen" / "shard-00000.npz.sha256").unlink()  # no digest: the structure check still catches it
    assert_one_line_error(run(ndrql_exe, work, "data", "show", "gen", "--png", "s.png"), "damaged shard")
    r = run(ndrql_exe, work, "data", "generate", "--family", "blocks", "--count", "4", "--size", "64", "--out", "gen",
            "--no-progress")
    assert r.returncode == 0 and shard.read_bytes() == data, r.stderr  # rebuilt, byte for byte


def test_a_file_in_the_way_of_an_output_folder(ndrql_exe, work):
    (work / "f").write_text("x")
    assert_one_line_error(run(ndrql_exe, work, "data", "generate", "--family", "blocks", "--count", "2", "--out",
                              "f/sub", "--no-progress"), "in the way")


# --- one meaning per pixel, no silent wrong results ------------------------------------------------


def _obstacle_ratio(exe, cwd: Path, name: str) -> str:
    r = run(exe, cwd, "map", "info", name)
    assert r.returncode == 0, r.stderr
    return next(line for line in r.stdout.splitlines() if line.startswith("obstacles:"))


def test_a_16_bit_pixel_means_the_same_whatever_the_others_hold(ndrql_exe, work):
    a = np.full((50, 60), 255 * 257, np.uint16)
    a[:, :30] = 255  # dark on the 16-bit scale
    Image.fromarray(a).save(work / "a.png")
    b = a.copy()
    b[0, 59] = 300  # one more dark pixel; before, every 255 flipped with it
    Image.fromarray(b).save(work / "b.png")
    assert _obstacle_ratio(ndrql_exe, work, "a.png") == "obstacles: 50.00%"
    assert _obstacle_ratio(ndrql_exe, work, "b.png") == "obstacles: 50.03%"


def test_nan_pixels_of_a_float_image_are_refused(ndrql_exe, work):
    a = np.ones((40, 40), np.float32)
    a[3, 3] = np.nan
    Image.fromarray(a).save(work / "nan.tiff")
    assert_one_line_error(run(ndrql_exe, work, "astar", "nan.tiff", "--start", "0,0", "--goal", "39,39"), "NaN")


@pytest.mark.parametrize("flag, value", [("--reward-goal", "inf"), ("--r0", "nan"), ("--reward-collision", "-1e400"),
                                         ("--max-episodes", "100000000")])
def test_non_finite_constants_are_refused(ndrql_exe, work, flag, value):
    assert_one_line_error(run(ndrql_exe, work, "plan", "block.png", *POINTS, "--method", "QL", f"{flag}={value}"))


def test_a_duplicate_yaml_key_is_refused(ndrql_exe, work):
    (work / "dup.yaml").write_text("image: block.png\nresolution: 0.05\nresolution: 0.5\norigin: [0, 0, 0]\n"
                                   "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    assert_one_line_error(run(ndrql_exe, work, "map", "info", "dup.yaml"), "given twice")


def test_a_scen_for_another_map_is_warned_about(ndrql_exe, work):
    (work / "a.map").write_text("type octile\nheight 100\nwidth 120\nmap\n" + "\n".join(["." * 120] * 100) + "\n")
    (work / "b.scen").write_text("version 1\n0\tother.map\t120\t100\t1\t1\t100\t90\t50.0\n")
    r = run(ndrql_exe, work, "astar", "a.map", "--scen", "b.scen")
    assert r.returncode == 0, r.stderr
    assert "written for the map other.map" in r.stderr and "shorter than the straight octile distance" in r.stderr


# --- messages ---------------------------------------------------------------------------------------


def test_start_equal_goal_under_size_auto_says_so(ndrql_exe, work):
    line = assert_one_line_error(run(ndrql_exe, work, "plan", "block.png", "--start", "5,5", "--goal", "5,5"))
    assert "same pixel" in line and "passage" not in line


def test_control_characters_from_a_yaml_are_escaped(ndrql_exe, work):
    (work / "evil.yaml").write_text('image: "\\e]0;HACKED\\a\\e[31mred.png"\nresolution: 0.05\norigin: [0, 0, 0]\n'
                                    "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    line = assert_one_line_error(run(ndrql_exe, work, "map", "info", "evil.yaml"), "not found")
    assert "\x1b" not in line and "\x07" not in line and "\\x1b" in line


def test_a_pickled_checkpoint_gives_no_advice_to_load_it_unsafely(ndrql_exe, work):
    pytest.importorskip("torch")
    with open(work / "evil.pt", "wb") as f:  # a pickle of an object: refused by weights_only loading
        pickle.dump({"obj": Path("x")}, f)
    line = assert_one_line_error(run(ndrql_exe, work, "plan", "block.png", *POINTS, "--weights", "evil.pt",
                                     "--backend", "torch"))
    assert "weights_only" not in line and "False" not in line, line


def test_a_prior_file_that_needs_unpickling_gives_no_advice_to_load_it_unsafely(ndrql_exe, work):
    line = assert_one_line_error(run(ndrql_exe, work, "plan", "block.png", *POINTS, "--method", "N-Q",
                                     "--prior-from", "block.png"), "unpickling")
    assert "allow_pickle" not in line and "trust" not in line, line
