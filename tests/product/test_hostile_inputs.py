"""Hostile and careless input through ``ndrql``'s command line (``main()`` as the console script runs it).

Every case: exit code 2 and exactly one ``ndrql: error: ...`` line on stderr (or, where the input is
legitimate, success), nothing outside the output replaced, no temporary files left behind. The
memory cases run under an address-space cap of about 2 GB (``RLIMIT_AS``), checked first against a
normal command, so a regression shows up as "out of memory" instead of swapping the machine; they share
one child process under that cap (``helpers.child``), which starts the interpreter and torch once.
"""

from __future__ import annotations

import ctypes
import json
import os
import re
import resource
import stat
import subprocess
import threading
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from helpers.child import CommandChild
from helpers.cli import assert_one_line_error, run_cli
from helpers.synthetic_dataset import make_tiny_dataset

CAP = 2 << 30  # bytes of address space for the memory cases
IS_ROOT = os.geteuid() == 0


def _cap_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (CAP, CAP))


#: The capped commands share one child process under the cap (one interpreter and torch for all of them).
CAPPED = CommandChild(_cap_memory)


@pytest.fixture(scope="module", autouse=True)
def _capped_child():
    yield
    CAPPED.close()


def run(exe: list[str], *args: str, cwd: Path, cap: bool = False, env: dict | None = None, preexec=None,
        timeout: float = 600) -> subprocess.CompletedProcess:
    """Run ``ndrql ARGS`` in ``cwd`` with a cache of its own there (and the memory cap when ``cap``: in the
    shared capped child, or a child of its own when ``NDRQL_TEST_CHILD=1``)."""
    full_env = {**os.environ, "NDRQL_CACHE": str(cwd / ".cache"), **(env or {})}
    if cap and preexec is None and os.environ.get("NDRQL_TEST_CHILD") != "1":
        return CAPPED.run(*args, cwd=cwd, env=full_env, timeout=timeout)
    return run_cli(exe, *args, cwd=cwd, env=full_env, timeout=timeout,
                   preexec_fn=preexec or (_cap_memory if cap else None))


def one_error(r: subprocess.CompletedProcess, pattern: str) -> str:
    """The one-line error (exit code 2), at most 500 characters (no unbounded input echoed), matching ``pattern``."""
    line = assert_one_line_error(r)
    assert len(line) <= 500, line[:600]
    assert re.search(pattern, line), line
    return line


def listing(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name != ".cache")


@pytest.fixture()
def work(tmp_path: Path) -> Path:
    """A folder with a small free map (100 x 120 px) and a map with an obstacle block."""
    Image.fromarray(np.full((100, 120), 255, np.uint8)).save(tmp_path / "small.png")
    arr = np.full((100, 120), 255, np.uint8)
    arr[40:60, 50:70] = 0
    Image.fromarray(arr).save(tmp_path / "block.png")
    return tmp_path


ASTAR = ("astar", "small.png", "--start", "1,1", "--goal", "90,100", "--grid", "area")  # the paper's grid: 86 moves


# --- 1. outputs: never replace what is at the target ------------------------------------------------


def test_json_to_a_character_device_writes_it_and_leaves_it(ndrql_exe, work):
    node = work / "null"
    try:
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # a /dev/null of our own
    except OSError:
        pytest.skip("cannot create a character device here (needs root)")
    (work / "link.json").symlink_to(node)
    before = os.lstat(node)
    for target in ("null", "link.json"):
        r = run(ndrql_exe, *ASTAR, "--json", target, cwd=work)
        assert r.returncode == 0, r.stderr
    after = os.lstat(node)
    assert stat.S_ISCHR(after.st_mode) and (after.st_ino, after.st_rdev) == (before.st_ino, before.st_rdev)
    assert (work / "link.json").is_symlink() and listing(work) == ["block.png", "link.json", "null", "small.png"]


def test_json_to_a_fifo_goes_through_the_pipe(ndrql_exe, work):
    fifo = work / "pipe"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    r = run(ndrql_exe, *ASTAR, "--json", "pipe", cwd=work)
    reader.join(timeout=60)
    assert r.returncode == 0, r.stderr
    assert json.loads(got[0])["length"] == 86 and stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_symlinked_output_is_refused_and_its_target_kept(ndrql_exe, work):
    (work / "real").mkdir()
    (work / "real" / "out.json").write_text("old")
    (work / "out.json").symlink_to(work / "real" / "out.json")
    r = run(ndrql_exe, *ASTAR, "--json", "out.json", cwd=work)
    assert r.returncode == 2 and "symbolic link" in r.stderr, r.stderr
    assert (work / "out.json").is_symlink() and (work / "real" / "out.json").read_text() == "old"
    assert listing(work / "real") == ["out.json"]


@pytest.mark.parametrize("umask", [0o022, 0o077])
def test_outputs_get_the_umask_permissions(ndrql_exe, work, umask):
    r = run(ndrql_exe, *ASTAR, "--json", "a.json", "--png", "a.png", cwd=work, preexec=lambda: os.umask(umask))
    assert r.returncode == 0, r.stderr
    for name in ("a.json", "a.png"):
        assert stat.S_IMODE((work / name).stat().st_mode) == 0o666 & ~umask


# --- 2. output path problems: one line, no debris ----------------------------------------------------


def _drop_dac_override() -> None:
    """In the child: root loses its permission-check bypass (so a read-only folder is read-only)."""
    libc = ctypes.CDLL(None, use_errno=True)
    for cap in (1, 2):  # CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH, dropped from the bounding set before exec
        if libc.prctl(24, cap, 0, 0, 0) != 0:  # PR_CAPBSET_DROP
            os._exit(97)


def test_read_only_folder(ndrql_exe, work):
    ro = work / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        r = run(ndrql_exe, *ASTAR, "--json", "ro/x.json", cwd=work, preexec=_drop_dac_override if IS_ROOT else None)
        if r.returncode == 97:
            pytest.skip("cannot drop CAP_DAC_OVERRIDE here")
        one_error(r, r"^ndrql: error: cannot write ro/x\.json: Permission denied$")
        assert listing(ro) == []
    finally:
        ro.chmod(0o755)


@pytest.mark.parametrize("args, pattern", [
    (("--json", "adir"), r"cannot write adir: it is a folder"),
    (("--png", "isdir.png"), r"cannot write isdir\.png: it is a folder"),
    (("--json", "afile/x.json"), r"cannot write afile/x\.json: a file is in the way \(afile\)"),
])
def test_output_path_in_the_way(ndrql_exe, work, args, pattern):
    (work / "adir").mkdir()
    (work / "isdir.png").mkdir()
    (work / "afile").write_text("keep")
    before = listing(work)
    one_error(run(ndrql_exe, *ASTAR, *args, cwd=work), pattern)
    assert listing(work) == before and listing(work / "adir") == [] and listing(work / "isdir.png") == []
    assert (work / "afile").read_text() == "keep"


def test_predict_out_on_an_existing_file(ndrql_exe, work):
    (work / "afile").write_text("keep")
    one_error(run(ndrql_exe, "predict", "small.png", "--start", "1,1", "--goal", "90,100", "--out", "afile", cwd=work),
              r"cannot create folder afile: a file is in the way")
    assert (work / "afile").read_text() == "keep"


# --- 3. memory bounded by the input's size -------------------------------------------------------------


def test_memory_cap_leaves_room_for_a_normal_command(ndrql_exe, work):
    """The cap is meaningful: ordinary commands (numba kernel, ONNX model) run under it."""
    r = run(ndrql_exe, *ASTAR, cwd=work, cap=True)
    assert r.returncode == 0, r.stderr
    r = run(ndrql_exe, "plan", "small.png", "--start", "1,1", "--goal", "90,100", "--method", "QL", cwd=work, cap=True)
    assert r.returncode == 0, r.stderr


def _alias_bomb(key: str) -> str:
    """A ROS map YAML of about 500 bytes whose ``key`` is 9**9 strings when expanded ("billion laughs")."""
    lines = ['a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    prev = "a"
    for name in "bcdefghi":
        lines.append(f"{name}: &{name} [" + ",".join([f"*{prev}"] * 9) + "]")
        prev = name
    fields = {"image": "small.png", "resolution": "0.05", "origin": "[0, 0, 0]", "occupied_thresh": "0.65",
              "free_thresh": "0.196", "negate": "0", "mode": "trinary"}
    fields[key] = f"*{prev}"
    return "\n".join(lines) + "\n" + "".join(f"{k}: {v}\n" for k, v in fields.items())


@pytest.mark.parametrize("key", ["resolution", "origin", "mode", "negate"])
def test_yaml_alias_bomb(ndrql_exe, work, key):
    (work / "bomb.yaml").write_text(_alias_bomb(key))
    assert (work / "bomb.yaml").stat().st_size < 700
    one_error(run(ndrql_exe, "map", "info", "bomb.yaml", cwd=work, cap=True), rf"'?{key}'?.*a list of 9 items")


@pytest.mark.parametrize("key, value", [("resolution", "9" * 400), ("origin", f"[{'9' * 400}, 0, 0]"),
                                        ("resolution", ".inf"), ("origin", "[0, .nan, 0]")])
def test_yaml_numbers_out_of_range(ndrql_exe, work, key, value):
    fields = {"image": "small.png", "resolution": "0.05", "origin": "[0, 0, 0]", "occupied_thresh": "0.65",
              "free_thresh": "0.196"}
    fields[key] = value
    (work / "m.yaml").write_text("".join(f"{k}: {v}\n" for k, v in fields.items()))
    one_error(run(ndrql_exe, "map", "info", "m.yaml", cwd=work), rf"'{key}' must (be|hold) finite")


def test_image_over_the_pixel_limit_is_refused_from_its_header(ndrql_exe, work):
    Image.new("L", (10_000, 10_000), 255).save(work / "big.png", optimize=True)  # ~120 KB file, 10^8 pixels
    assert (work / "big.png").stat().st_size < 300_000
    for cmd in (("map", "info", "big.png"), ("astar", "big.png", "--start", "1,1", "--goal", "9,9")):
        one_error(run(ndrql_exe, *cmd, cwd=work, cap=True), r"map is 10000x10000 = 100,000,000 pixels, more than the limit")
    one_error(run(ndrql_exe, "map", "info", "big.png", "--max-pixels", "1000", cwd=work), r"more than the limit of 1,000")
    one_error(run(ndrql_exe, "map", "info", "small.png", "--max-pixels", "0", cwd=work), r"--max-pixels must be")


def test_npy_and_movingai_headers_claiming_huge_maps(ndrql_exe, work):
    header = np.lib.format.header_data_from_array_1_0(np.zeros((1, 1), bool))
    header["shape"] = (100_000, 100_000)
    with open(work / "huge.npy", "wb") as fh:  # a 10^10-cell header, 128 bytes of file
        np.lib.format.write_array_header_1_0(fh, header)
    one_error(run(ndrql_exe, "map", "info", "huge.npy", cwd=work, cap=True), r"cannot read \.npy map|more than the limit")
    (work / "huge.map").write_text("type octile\nheight 100000\nwidth 100000\nmap\n....\n")
    one_error(run(ndrql_exe, "map", "info", "huge.map", cwd=work, cap=True), r"more than the limit")


def test_one_row_map_of_16m_pixels_plans_in_bounded_memory(ndrql_exe, work):
    Image.new("L", (16_777_216, 1), 255).save(work / "wide.png", optimize=True)  # 16 KB file
    r = run(ndrql_exe, "astar", "wide.png", "--start", "0,0", "--goal", "0,16777215", "--grid", "area", cwd=work, cap=True)
    assert "out of memory" not in r.stderr and "MemoryError" not in r.stderr
    assert r.returncode in (0, 2) and len(r.stderr.splitlines()) <= 1, r.stderr[-2000:]


@pytest.mark.parametrize("args, pattern", [
    (("plan", "small.png", "--start", "1,1", "--goal", "90,100", "--seeds", "1000000000"), r"--seeds must be .* 1\.\.10,000"),
    (("astar", "small.png", "--start", "1,1", "--goal", "90,100", "--size", "20000"), r"--size must be .* 2\.\.1,024"),
    (("map", "info", "small.png", "--size", "0"), r"--size must be"),
    (("demo", "--seeds", "100000000"), r"--seeds must be"),
    (("plan", "small.png", "--start", "1,1", "--goal", "90,100", "--workers", "100000"), r"--workers must be"),
])
def test_counts_and_sizes_are_bounded(ndrql_exe, work, args, pattern):
    one_error(run(ndrql_exe, *args, cwd=work, cap=True), pattern)


# --- 4. numbers out of range -------------------------------------------------------------------------------


@pytest.mark.parametrize("seed, seeds, pattern", [
    (str(2**63), "1", r"--seed must be an integer in 0\.\.2\*\*63 - 1"),
    (str(2**63 - 1), "2", r"--seed must be an integer in 0\.\.2\*\*63 - 2"),
    ("-1", "1", r"--seed must be"),
])
def test_seed_range(ndrql_exe, work, seed, seeds, pattern):
    one_error(run(ndrql_exe, "plan", "small.png", "--start", "1,1", "--goal", "90,100", "--method", "QL",
                  "--seed", seed, "--seeds", seeds, cwd=work), pattern)


def test_largest_seed_runs(ndrql_exe, work):
    r = run(ndrql_exe, "plan", "small.png", "--start", "1,1", "--goal", "90,100", "--method", "QL",
            "--seed", str(2**63 - 1), cwd=work)
    assert r.returncode == 0 and f"QL seed {2**63 - 1}: converged" in r.stdout, r.stderr


@pytest.mark.parametrize("args, pattern", [
    (("--batch-size", "0"), r"--batch-size must be an integer in 1\.\."),
    (("--model", "nope"), r"unknown model 'nope'; valid: ndr-stdc1"),
    (("--val-fraction", "1.5"), r"--val-fraction must be a finite number in"),
    (("--epochs", "0"), r"--epochs must be an integer in 1\.\."),
    (("--model-overrides", '{"width": -1}'), r"'width' must be in"),
    (("--model-overrides", '{"unet_base": 100000}'), r"'unet_base' must be in"),
    (("--lr", "nan"), r"--lr must be a finite number"),
    (("--seed", str(2**63)), r"--seed must be an integer in 0\.\.2\*\*63 - 1"),
    (("--resume", "--run-dir", "norun"), r"--resume: there is no norun/last\.pt to continue"),
    (("--threads", "-3"), r"--threads must be an integer in 1\.\.\d+ \(or 0\)"),
])
def test_train_flags_are_validated_at_the_boundary(ndrql_exe, work, args, pattern):
    one_error(run(ndrql_exe, "train", "--data", str(work / "no-dataset"), *args, cwd=work), pattern)
    assert not (work / "norun").exists()


# --- 5. crafted checkpoints ----------------------------------------------------------------------------------


@pytest.mark.parametrize("config, pattern", [
    ([1, 2, 3], r"a model config is a mapping"),
    ({"arch": [1, 2, 3]}, r"unknown architecture a list of 3 items"),
    ({"arch": "ndr", "unet_base": -3}, r"'unet_base' must be in 1\.\.256, got -3"),
    ({"arch": "ndr", "width": 64}, r"'width' must be in .*got 64"),
    ({"arch": "ndr", "width": float("nan")}, r"'width' must be like"),
    ({"arch": "ndr", "backbone": "x" * 10_000}, r"unknown backbone 'x{40}'\.\.\. in the model config"),
])
@pytest.mark.slow
def test_crafted_checkpoint_configs(ndrql_exe, work, config, pattern):
    import torch

    torch.save({"format": "ndrql-checkpoint", "format_version": 1, "config": config, "model": {}}, work / "bad.pt")
    args = ("predict", "small.png", "--start", "1,1", "--goal", "90,100", "--weights", "bad.pt", "--out", "o")
    for backend in ("torch", "onnx"):
        one_error(run(ndrql_exe, *args, "--backend", backend, cwd=work, cap=True), pattern)
    one_error(run(ndrql_exe, "export-weights", "bad.pt", "--out", "slim.pt", cwd=work, cap=True), pattern)
    assert not (work / "slim.pt").exists()


# --- 6. caches repair themselves -----------------------------------------------------------------------------


@pytest.mark.slow
def test_truncated_onnx_export_is_rebuilt_once(ndrql_exe, work, user_weights):
    pytest.importorskip("onnxruntime")
    args = ("predict", "small.png", "--start", "1,1", "--goal", "90,100", "--out", "o", "--backend", "onnx",
            "--weights", str(user_weights))
    r = run(ndrql_exe, *args, cwd=work)
    assert r.returncode == 0, r.stderr
    (onnx,) = (work / ".cache" / "onnx").glob("*.onnx")
    good = onnx.read_bytes()
    onnx.write_bytes(good[: len(good) // 3])
    r = run(ndrql_exe, *args, cwd=work)
    assert r.returncode == 0, r.stderr
    assert r.stderr.count("\n") == 1 and "is damaged; exporting it again" in r.stderr, r.stderr
    assert onnx.read_bytes() == good
    r = run(ndrql_exe, *args, cwd=work)
    assert r.returncode == 0 and r.stderr == "", r.stderr


@pytest.mark.slow
def test_truncated_dataset_cache_is_decoded_again(ndrql_exe, work, model_weights):
    root = make_tiny_dataset(work / "ds", n_train=8, n_test=4)
    args = ("eval", "--data", str(root), "--split", "seen", "--threads", "1")
    r = run(ndrql_exe, *args, cwd=work)
    assert r.returncode == 0, r.stderr[-2000:]
    (cache,) = (work / ".cache" / "dataset").glob("*/seen.npz")
    assert cache.with_name("seen.npz.sha256").is_file()
    cache.write_bytes(cache.read_bytes()[:1000])
    r = run(ndrql_exe, *args, cwd=work)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "is damaged" in r.stderr and "decoding the seen split again" in r.stderr
    assert "BadZipFile" not in r.stderr.replace("(BadZipFile)", "") and "Traceback" not in r.stderr
    r2 = run(ndrql_exe, *args, cwd=work)
    assert r2.returncode == 0 and "damaged" not in r2.stderr


# --- 8. small ones ---------------------------------------------------------------------------------------------------


def test_argparse_errors_are_one_line(ndrql_exe, work):
    one_error(run(ndrql_exe, "plan", "--bogus", cwd=work), r"unrecognized arguments: --bogus")
    one_error(run(ndrql_exe, "astar", "--size", "x" * 100_000, cwd=work), r"invalid grid_size value: 'x+\.\.\.")
    one_error(run(ndrql_exe, "map", cwd=work), r"required: ACTION|the following arguments are required")
    one_error(run(ndrql_exe, "nope", cwd=work), r"invalid choice")


def test_start_on_an_obstacle_is_one_rule_for_astar_plan_and_predict(ndrql_exe, work):
    for cmd in ("astar", "plan", "predict"):
        one_error(run(ndrql_exe, cmd, "block.png", "--start", "50,60", "--goal", "90,100", cwd=work),
                  r"start 50,60 is on an obstacle of the map")


def test_scenario_index_errors(ndrql_exe, work):
    (work / "m.map").write_text("type octile\nheight 2\nwidth 3\nmap\n...\n...\n")
    (work / "m.map.scen").write_text("version 1\n0\tm.map\t3\t2\t0\t0\t2\t1\t2.41421356\n")
    one_error(run(ndrql_exe, "astar", "m.map", "--scen", "m.map.scen:-1", cwd=work), r"scenario -1 not in m\.map\.scen: it has scenarios 0\.\.0")
    one_error(run(ndrql_exe, "astar", "m.map", "--scen", "m.map.scen:5", cwd=work), r"scenario 5 not in")
    r = run(ndrql_exe, "astar", "m.map", "--scen", "m.map.scen:0", "--octile", cwd=work)
    assert r.returncode == 0 and "length 2.414214" in r.stdout, r.stderr


@pytest.mark.parametrize("args, pattern", [
    (("astar", "small.png", "--start", "1,1", "--goal", "90,100", "--threshold", "nan"), r"--threshold must be a finite"),
    (("astar", "small.png", "--start", "1" * 5000 + ",1", "--goal", "90,100"), r"--start must be ROW,COL"),
    (("predict", "small.png", "--start", "1,1", "--goal", "90,100", "--threads", "0"), r"--threads must be an integer in 1\.\."),
    (("eval", "--batch-size", "0"), r"--batch-size must be"),
    (("export-onnx", "--out", "x.onnx", "--size", "100000"), r"--size must be"),
])
def test_other_flags_out_of_range(ndrql_exe, work, args, pattern):
    one_error(run(ndrql_exe, *args, cwd=work), pattern)
