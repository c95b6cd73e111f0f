"""The light install (``pip install ndrql``, no torch) plans with the shipped models.

The shipped ONNX graphs belong to the shipped checkpoints (SHA-256 in the record beside each graph;
``python tools/export_shipped_onnx.py`` regenerates them) and agree with torch to 1e-4. ``ndrql plan``
(paper and general weights), ``ndrql demo`` and the API run in a process where ``import torch`` fails,
without even trying it; a torch-only command there prints one line naming what to install, exit 2.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from ndrql.io import file_digest
from ndrql.model.export import max_differences
from ndrql.model.shipped import CHECK_SIDES, SHIPPED_BUDGET, TOLERANCE, graph_path, read_record, shipped_bytes, shipped_file
from ndrql.model.weights import SHIPPED_WEIGHTS, installed

from helpers import REPO_ROOT

SAMPLE = REPO_ROOT / "src" / "ndrql" / "data" / "sample_map.png"
START_GOAL = ("--start", "25,179", "--goal", "167,5")
REGENERATE = "regenerate the shipped graphs: python tools/export_shipped_onnx.py"


#: Every shipped model installed: the named weights (``belief`` once trained: its checkpoint, graph and record ship
#: together) and general's large-grid companion.
ALL_SHIPPED = [*(n for n in SHIPPED_WEIGHTS if installed(n)), "ndr_general_large"]


@pytest.mark.parametrize("name", ALL_SHIPPED)
def test_shipped_graph_belongs_to_the_shipped_checkpoint(name):
    record = read_record(name)
    assert record is not None, f"no record beside {graph_path(name)}; {REGENERATE}"
    assert record["weights_sha256"] == file_digest(shipped_file(name)), \
        f"{shipped_file(name).name} changed since its graph was exported; {REGENERATE}"
    assert record["onnx_sha256"] == file_digest(graph_path(name)), f"{graph_path(name).name} is damaged; {REGENERATE}"


@pytest.mark.parametrize("name", ALL_SHIPPED)
def test_recorded_differences_cover_every_side_plan_uses(name):
    measured = read_record(name)["max_abs_difference"]
    assert {int(side) for side in measured} >= set(CHECK_SIDES)
    assert {128, 201, 1024, 2048} <= set(CHECK_SIDES)
    worst = {side: max(d.values()) for side, d in measured.items()}
    assert max(worst.values()) <= TOLERANCE, worst


def test_all_shipped_weights_fit_the_budget():
    assert shipped_bytes() <= SHIPPED_BUDGET
    assert all(graph_path(name).is_file() for name in ALL_SHIPPED)


@pytest.mark.parametrize(("name", "sides"), [("paper", (201, 256)), ("general", (128, 344)),
                                              ("ndr_general_large", (400, 512)),
                                              pytest.param("belief", (128, 344), marks=pytest.mark.skipif(
                                                  not installed("belief"), reason="ndr_belief.pt not shipped yet"))])
def test_shipped_graph_agrees_with_torch(name, sides):
    pytest.importorskip("torch")
    diffs = max_differences(shipped_file(name), graph_path(name), sides, count=1, seed=7)
    assert max(max(d.values()) for d in diffs.values()) <= TOLERANCE, diffs


# --- a process without torch ----------------------------------------------------------------------


@pytest.fixture()
def no_torch(tmp_path) -> dict[str, str]:
    """Environment of a process where ``import torch`` fails: a stand-in ``torch`` package first on the path
    that records the attempt in ``tried`` and raises ImportError."""
    fake = tmp_path / "fake" / "torch"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text(
        "import os\nopen(os.environ['NDRQL_TEST_TORCH_TRIED'], 'a').write('tried\\n')\n"
        "raise ImportError('torch is not installed (test stand-in)')\n")
    env = {k: v for k, v in os.environ.items() if k != "NDRQL_WEIGHTS"}
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(fake.parent), env.get("PYTHONPATH")) if p)
    env["NDRQL_TEST_TORCH_TRIED"] = str(tmp_path / "tried")
    env["NDRQL_CACHE"] = str(tmp_path / "cache")  # empty: nothing exported earlier helps
    return env


def torch_tried(env: dict[str, str]) -> bool:
    return Path(env["NDRQL_TEST_TORCH_TRIED"]).exists()


@pytest.mark.parametrize("weights", ["paper", "general"])
def test_plan_runs_without_torch(ndrql_exe, no_torch, tmp_path, weights):
    out = subprocess.run([*ndrql_exe, "plan", str(SAMPLE), *START_GOAL, "--weights", weights,
                          "--json", str(tmp_path / "r.json")], capture_output=True, text=True, env=no_torch, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stderr == ""
    assert f"ndr_{'default' if weights == 'paper' else weights}.pt (onnx)" in out.stdout  # one forward pass by default
    record = json.loads((tmp_path / "r.json").read_text())
    assert record["backend"] == "onnx" and record["runs"][0]["success"]
    assert not torch_tried(no_torch), "something on the plan path imported torch"


def test_demo_and_api_run_without_torch(ndrql_exe, no_torch, tmp_path):
    out = subprocess.run([*ndrql_exe, "demo", "--out", str(tmp_path / "demo")], capture_output=True, text=True,
                         env=no_torch, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "demo" / "results.json").is_file()
    code = ("import sys, ndrql; "
            f"run = ndrql.plan({str(SAMPLE)!r}, (25, 179), (167, 5), weights='general'); "
            "print(run.success, 'torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=no_torch, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["True", "False"]
    assert not torch_tried(no_torch)


@pytest.mark.parametrize("args", [
    ("train", "--run-dir", "run"),
    ("eval", "--split", "seen"),
    ("export-onnx", "--out", "x.onnx"),
    ("reproduce", "table4"),
    ("plan", str(SAMPLE), *START_GOAL, "--backend", "torch"),
    ("plan", str(SAMPLE), *START_GOAL, "--weights", "USER"),
], ids=["train", "eval", "export", "table4", "backend-torch", "user-checkpoint"])
def test_torch_only_commands_say_what_to_install(ndrql_exe, no_torch, tmp_path, user_weights, args):
    args = tuple(str(user_weights) if a == "USER" else a for a in args)
    out = subprocess.run([*ndrql_exe, *args], capture_output=True, text=True, env=no_torch, cwd=tmp_path)
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1, out.stderr
    assert out.stderr.startswith("ndrql: error: ") and out.stderr.rstrip().endswith("pip install 'ndrql[train]'")
    assert "needs torch" in out.stderr


def test_exported_graph_plans_without_torch(ndrql_exe, no_torch, tmp_path, user_weights):
    graph = tmp_path / "user.onnx"
    out = subprocess.run([*ndrql_exe, "export-onnx", "--weights", str(user_weights), "--out", str(graph)],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    out = subprocess.run([*ndrql_exe, "plan", str(SAMPLE), *START_GOAL, "--weights", str(graph)],
                         capture_output=True, text=True, env=no_torch, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "user.onnx (onnx" in out.stdout and not torch_tried(no_torch)
    out = subprocess.run([*ndrql_exe, "plan", str(SAMPLE), *START_GOAL, "--weights", str(SAMPLE.with_suffix(".json"))],
                         capture_output=True, text=True, env=no_torch, cwd=tmp_path)
    assert out.returncode == 2 and out.stderr.count("\n") == 1, out.stderr
