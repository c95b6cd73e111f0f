"""ONNX Runtime's optimised graph kept in ``$NDRQL_CACHE/onnx/ort``: made once, reused, the same outputs
bit for bit as a session that optimises the graph itself; a damaged file is made again, and a cache
folder that cannot be written costs only time."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from ndrql.model.onnx_backend import OnnxRunner, machine_key, onnx_available, optimized_path
from ndrql.model.predict import Predictor

from helpers.cli import run_cli

pytestmark = pytest.mark.skipif(not onnx_available(), reason="onnxruntime not installed")


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NDRQL_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def level(p: Predictor):
    import onnxruntime as ort

    got = p._runner.session.get_session_options().graph_optimization_level
    return {ort.GraphOptimizationLevel.ORT_DISABLE_ALL: "off", ort.GraphOptimizationLevel.ORT_ENABLE_ALL: "all"}.get(got, str(got))


def outputs(p: Predictor) -> list[np.ndarray]:
    """The bundled example as ``plan`` sees it, and a random planning grid."""
    from ndrql.maps.bundled import bundled_sample

    s = bundled_sample()
    a = p.predict(s.grid_map.obstacles, s.start, s.goal)
    rng = np.random.default_rng(7)
    blocked = rng.random((50, 50)) < 0.25
    blocked[3, 4] = blocked[44, 40] = False
    b = p.predict_grid_all(blocked, (3, 4), (44, 40))
    return [a.region, a.guideline, *[x for x in b if x is not None]]


def uncached(p: Predictor) -> Predictor:
    """``p`` on a session that optimises the graph itself (no cache)."""
    out = Predictor(OnnxRunner(p.graph_file, threads=1), p.encoding, p.input_mode, p.view)
    assert level(out) == "all"
    return out


def the_file(cache) -> "os.PathLike":
    (f,) = (cache / "onnx" / "ort").iterdir()
    return f


def test_made_once_reused_and_bit_for_bit(cache, model_weights):
    first = Predictor.load(model_weights, threads=1)
    f = the_file(cache)
    assert level(first) == "all" and f.suffix == ".onnx" and machine_key() in f.name
    import onnxruntime as ort

    assert f"-ort{ort.__version__}-" in f.name
    stamp = f.stat().st_mtime_ns
    second = Predictor.load(model_weights, threads=1)
    assert level(second) == "off" and the_file(cache) == f and f.stat().st_mtime_ns == stamp
    ref = outputs(uncached(first))
    for p in (first, second):
        got = outputs(p)
        assert len(got) == len(ref) and all(a.dtype == b.dtype and np.array_equal(a, b) for a, b in zip(got, ref))
    assert not [p for p in f.parent.iterdir() if p != f]  # no temporary file left


def test_the_name_holds_the_graph_the_version_and_the_machine(cache):
    a, b = optimized_path("a" * 64), optimized_path("b" * 64)
    assert a != b and a.parent == b.parent == cache / "onnx" / "ort"
    assert a.name.startswith("a" * 16 + "-ort") and a.name.endswith(f"-{machine_key()}.onnx")


@pytest.mark.parametrize("damage", ["garbage", "truncated", "empty"])
def test_a_damaged_file_is_made_again(cache, model_weights, damage):
    ref = outputs(Predictor.load(model_weights, threads=1))
    f = the_file(cache)
    good = f.read_bytes()
    bad = {"garbage": b"not a graph" * 100, "truncated": good[: len(good) // 2], "empty": b""}[damage]
    f.write_bytes(bad)
    again = Predictor.load(model_weights, threads=1)
    assert level(again) == "all" and the_file(cache) == f and f.read_bytes() != bad  # made again
    assert all(np.array_equal(a, b) for a, b in zip(outputs(again), ref))
    assert level(Predictor.load(model_weights, threads=1)) == "off"


def test_an_unwritable_cache_folder_still_predicts(tmp_path, monkeypatch, model_weights):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("NDRQL_CACHE", str(blocker / "cache"))  # nothing can be created below a file
    p = Predictor.load(model_weights, threads=1)
    assert level(p) == "all"
    assert all(np.array_equal(a, b) for a, b in zip(outputs(p), outputs(uncached(p))))
    assert not list(tmp_path.rglob("*.ndrql-tmp*"))


def _without_times(path) -> dict:
    data = json.loads(path.read_text())
    data.pop("timings")
    for run in data["runs"]:
        run.pop("wall_time")
    for trial in data.get("sources", []):
        trial.pop("seconds")
    return data


def test_plan_example_is_the_same_cold_warm_and_without_a_cache(tmp_path, ndrql_exe):
    cache = tmp_path / "cache"
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    runs = []
    for i, root in enumerate((cache, cache, blocker / "cache")):
        out = tmp_path / f"p{i}.json"
        r = run_cli(ndrql_exe, "plan", "--example", "--prior-from", "model", "--predict-budget", "none", "--json",
                    str(out), env={**os.environ, "NDRQL_CACHE": str(root)})
        assert r.returncode == 0, r.stderr
        assert "onnxruntime" not in r.stderr and "[W:" not in r.stderr  # ONNX Runtime's own warnings stay quiet
        runs.append(_without_times(out))
    assert runs[0] == runs[1] == runs[2]
    assert len(list((cache / "onnx" / "ort").iterdir())) == 1
