"""Inference backends of the Predictor: ONNX Runtime (default when installed) and torch agree; the
shipped weights run from their shipped graphs, other checkpoints are exported once into the cache
(by weights digest), a warm cache needs no torch, bad input gives clear errors."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from ndrql.errors import CheckpointError, NdrqlError
from ndrql.model.onnx_backend import onnx_available, onnx_cache_path
from ndrql.model.predict import Predictor

from helpers.cli import assert_one_line_error, run_cli

pytestmark = pytest.mark.skipif(not onnx_available(), reason="onnxruntime not installed")


def corridor_map() -> np.ndarray:
    m = np.zeros((201, 201), bool)
    m[60:70, :150] = True
    m[130:140, 50:] = True
    return m


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NDRQL_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_onnx_and_torch_predict_the_same(cache, user_weights):
    m = corridor_map()
    onnx = Predictor.load(user_weights, threads=1, backend="auto")
    torch_ = Predictor.load(user_weights, threads=1, backend="torch")
    assert onnx.backend_name == "onnx" and torch_.backend_name == "torch"
    a = onnx.predict(m, (10, 10), (190, 190))
    b = torch_.predict(m, (10, 10), (190, 190))
    assert a.region.shape == b.region.shape == (201, 201)
    assert np.abs(a.region - b.region).max() < 1e-3 and np.abs(a.guideline - b.guideline).max() < 1e-3
    # and the thresholded masks the planners use are the same
    assert ((a.region >= 0.5) != (b.region >= 0.5)).sum() <= 2
    assert onnx_cache_path(user_weights).is_file()


def test_an_export_removes_the_per_side_exports_of_earlier_versions(cache, user_weights):
    path = onnx_cache_path(user_weights)
    path.parent.mkdir(parents=True)
    digest = path.name.split("-")[0]
    stale = [path.parent / f"{digest}{end}" for end in (".onnx", ".json", "-320.onnx", "-320.json", "-1024.onnx")]
    kept = [path.parent / f"{'0' * 16}-320.onnx", path.parent / f"{digest}-notes.txt"]  # other weights, not ours
    for f in stale + kept:
        f.write_bytes(b"old")
    Predictor.load(user_weights, threads=1, backend="onnx")  # exports into the cache
    assert path.is_file() and path.with_suffix(".json").is_file()
    assert not [f for f in stale if f.exists()] and all(f.exists() for f in kept)


def test_shipped_weights_need_no_export(cache, model_weights):
    p = Predictor.load(model_weights, threads=1)
    assert p.backend_name == "onnx" and p._runner.path.suffix == ".onnx"
    assert p._runner.path.parent == model_weights.parent  # the shipped graph, no export in the cache
    assert not [f for f in (cache / "onnx").glob("*") if f.name != "ort"]  # ort: ONNX Runtime's optimised graph


def test_warm_cache_loads_without_torch(cache, user_weights):
    Predictor.load(user_weights, backend="onnx")  # export once
    code = ("import sys, numpy as np; from ndrql.model.predict import Predictor; "
            f"p = Predictor.load({str(user_weights)!r}, threads=1); "
            "r = p.predict(np.zeros((120, 90), bool), (5, 5), (110, 80)); "
            "print(p.backend_name, r.region.shape, 'torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={**__import__("os").environ, "NDRQL_CACHE": str(cache)})
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["onnx", "(120,", "90)", "False"]


def test_damaged_export_cache_is_rebuilt(cache, user_weights):
    p = Predictor.load(user_weights, backend="onnx")
    meta = onnx_cache_path(user_weights).with_suffix(".json")
    meta.write_text("{not json")
    onnx_cache_path(user_weights).unlink()
    q = Predictor.load(user_weights, backend="onnx")
    assert json.loads(meta.read_text())["exported"] is True
    m = corridor_map()
    assert np.array_equal(p.predict(m, (10, 10), (190, 190)).region, q.predict(m, (10, 10), (190, 190)).region)


def test_backend_errors(cache, model_weights, tmp_path):
    with pytest.raises(NdrqlError, match="unknown inference backend 'cuda'; valid: auto, onnx, torch"):
        Predictor.load(model_weights, backend="cuda")
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a checkpoint")
    with pytest.raises(CheckpointError, match="cannot read checkpoint"):
        Predictor.load(bad, backend="onnx")
    with pytest.raises(CheckpointError, match="missing model weights"):
        Predictor.load(tmp_path / "none.pt")
    with pytest.raises(AttributeError, match="backend='torch'"):
        Predictor.load(model_weights, backend="onnx").model


def test_model_without_guideline_runs_on_torch_under_auto(cache, tmp_path):
    import torch

    from ndrql.model.registry import build_model, preset
    from ndrql.model.checkpoint import save_checkpoint

    cfg = preset("ndr-stdc1-half-noguide", width=0.25)
    torch.manual_seed(0)
    save_checkpoint(tmp_path / "noguide.pt", {"config": cfg, "model": build_model(cfg).state_dict()})
    p = Predictor.load(tmp_path / "noguide.pt", backend="auto")
    assert p.backend_name == "torch" and p.predict(corridor_map(), (10, 10), (190, 190)).guideline is None
    with pytest.raises(NdrqlError, match="without a guideline output"):
        Predictor.load(tmp_path / "noguide.pt", backend="onnx")


@pytest.mark.slow
def test_cli_backend_flags(cache, model_weights, ndrql_exe, tmp_path):
    import os

    env = {**os.environ, "NDRQL_CACHE": str(cache)}
    m = tmp_path / "m.npy"
    np.save(m, corridor_map())
    out = run_cli(ndrql_exe, "plan", str(m), "--start", "10,10", "--goal", "190,190", "--backend", "torch", "--predict-budget", "none",
                  "--json", str(tmp_path / "t.json"), env=env)
    assert out.returncode == 0, out.stderr
    assert "(torch" in out.stdout and json.loads((tmp_path / "t.json").read_text())["backend"] == "torch"
    out = run_cli(ndrql_exe, "plan", str(m), "--start", "10,10", "--goal", "190,190", "--prior-from", "model",
                  "--predict-budget", "none", "--json", str(tmp_path / "o.json"), env=env)
    assert out.returncode == 0, out.stderr
    assert json.loads((tmp_path / "o.json").read_text())["backend"] == "onnx"
    out = run_cli(ndrql_exe, "predict", str(m), "--start", "10,10", "--goal", "190,190", "--backend", "gpu", env=env)
    assert_one_line_error(out, "invalid choice: 'gpu'")


def test_unwritable_cache_falls_back_to_torch_under_auto(tmp_path, monkeypatch, model_weights, user_weights):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    monkeypatch.setenv("NDRQL_CACHE", str(blocker / "cache"))  # mkdir fails below a file
    with pytest.warns(UserWarning, match="using torch"):
        p = Predictor.load(user_weights, backend="auto")
    assert p.backend_name == "torch"
    with pytest.raises(NdrqlError, match="ONNX Runtime backend failed"):
        Predictor.load(user_weights, backend="onnx")
    assert Predictor.load(model_weights).backend_name == "onnx"  # the shipped graph needs no cache
