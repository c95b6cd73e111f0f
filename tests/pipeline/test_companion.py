"""Companion weights (:mod:`ndrql.model.companion`): the base's config names, in ``merged_weights``, a second
model that serves every grid the base's view merges. Under ``coarse:16`` a grid of at most 16 cells is the
base's, bit for bit; a 32-cell grid (merged 2x2) is the companion's own prediction, bit for bit, on torch
and on ONNX Runtime, through ``plan`` and the tables' prediction cache, whose entries never cross."""

from __future__ import annotations

import json

import numpy as np
import pytest

import ndrql
from ndrql.errors import NdrqlError
from ndrql.model.companion import check_stem, weights_digest
from ndrql.model.onnx_backend import CONFIG_KEY as ONNX_CONFIG_KEY, onnx_available
from ndrql.model.predict import Predictor

VIEW = "coarse:16"
START, GOAL = (1, 1), (14, 14)


def _grid(n: int) -> np.ndarray:
    """A ``n`` x ``n`` grid with a wall that leaves a gap (start top left, goal bottom right, scaled)."""
    blocked = np.zeros((n, n), bool)
    blocked[n // 2, : n - n // 4] = True
    return blocked


def _points(n: int) -> tuple[tuple[int, int], tuple[int, int]]:
    return (1, 1), (n - 2, n - 2)


def _checkpoint(model_weights, path, scale: float = 1.0, **config):
    """The shipped checkpoint saved again with ``config`` in its model config, its first convolution's
    weights scaled by ``scale`` (a perturbed model: a stand-in companion)."""
    from ndrql.model.checkpoint import load_checkpoint, save_checkpoint

    data = load_checkpoint(model_weights)
    payload = {k: v for k, v in data.items() if k not in ("format", "format_version", "ndrql_version")}
    shipped = {k: v for k, v in dict(data["config"]).items() if k != "merged_weights"}  # the shipped base names one
    payload["config"] = {**shipped, "view": VIEW, **config}
    if scale != 1.0:
        model = dict(data["model"])
        key = next(k for k, v in model.items() if v.ndim == 4)
        model[key] = (model[key].float() * scale).to(model[key].dtype)
        payload["model"] = model
    return save_checkpoint(path, payload)


def _graph(model_weights, path, scale: float = 1.0, **config):
    """The shipped ONNX graph with ``config`` in its metadata's model config and its first 4-D fp16
    initializer scaled by ``scale`` (no export: onnx edits the graph)."""
    onnx = pytest.importorskip("onnx")
    from onnx import numpy_helper

    graph = onnx.load(str(model_weights.with_suffix(".onnx")))
    props = {p.key: p.value for p in graph.metadata_props}
    shipped = {k: v for k, v in json.loads(props[ONNX_CONFIG_KEY]).items() if k != "merged_weights"}
    props[ONNX_CONFIG_KEY] = json.dumps({**shipped, "view": VIEW, **config}, sort_keys=True)
    del graph.metadata_props[:]
    onnx.helper.set_model_props(graph, props)
    if scale != 1.0:
        init = next(i for i in graph.graph.initializer if len(i.dims) == 4)
        a = numpy_helper.to_array(init)
        init.CopyFrom(numpy_helper.from_array((a.astype(np.float32) * scale).astype(a.dtype), init.name))
    onnx.save(graph, str(path))
    return path


@pytest.fixture(params=["torch", "onnx"])
def trio(request, model_weights, tmp_path):
    """``(backend, base, companion, plain)``: the base naming the companion, the companion (perturbed), and
    the base without the key, all under ``coarse:16``, as checkpoints (torch) or graphs (ONNX)."""
    backend = request.param
    if backend == "torch":
        pytest.importorskip("torch")
        make, suffix = _checkpoint, ".pt"
    else:
        if not onnx_available():
            pytest.skip("onnxruntime not installed")
        make, suffix = _graph, ".onnx"
    base = make(model_weights, tmp_path / f"base{suffix}", merged_weights="comp")
    comp = make(model_weights, tmp_path / f"comp{suffix}", scale=1.5)
    plain = make(model_weights, tmp_path / f"plain{suffix}")
    return backend, base, comp, plain


def _all(p: Predictor, n: int) -> list[np.ndarray]:
    """Every per-cell and 4 px output of ``p`` on the ``n``-cell test grid, and its map prediction."""
    blocked = _grid(n)
    s, g = _points(n)
    view = p.predict_view(blocked, s, g)
    return [view.region, view.guideline, view.distance, *p.predict_cells(blocked, s, g),
            *p.predict_grid_all(blocked, s, g)]


def _same(a: list[np.ndarray], b: list[np.ndarray]) -> bool:
    return all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def test_base_serves_unmerged_grids_and_the_companion_merged_ones(trio):
    backend, base, comp, plain = trio
    for turns in (1, 2):
        b = Predictor.load(base, threads=1, backend=backend, symmetries=turns)
        c = Predictor.load(comp, threads=1, backend=backend, symmetries=turns)
        p = Predictor.load(plain, threads=1, backend=backend, symmetries=turns)
        assert b.merged_weights == comp.parent / comp.name and c.merged_weights is None
        small = _all(b, 16)
        assert not b._companion  # nothing merged yet: the companion is not even loaded
        assert _same(small, _all(p, 16)) and not _same(small, _all(c, 16))
        large = _all(b, 32)
        assert b.serving(32).weights_file == comp and b.serving(32).symmetries == turns
        assert b.serving(32).backend_name == backend and b.serving(16) is b
        assert _same(large, _all(c, 32)) and not _same(large, _all(p, 32))
    with_turns = Predictor.load(base, threads=1, backend=backend).with_symmetries(4)
    assert with_turns.serving(32).symmetries == 4 and with_turns.merged_weights == b.merged_weights


def test_missing_or_mismatched_companion_is_one_clear_error(model_weights, tmp_path):
    pytest.importorskip("torch")
    base = _checkpoint(model_weights, tmp_path / "base.pt", merged_weights="nope")
    b = Predictor.load(base, threads=1, backend="torch")
    b.predict_view(_grid(16), *_points(16))  # unmerged: the base alone
    with pytest.raises(NdrqlError, match=r"missing companion weights .*nope\.pt \(named by merged_weights in base\.pt"):
        b.predict_view(_grid(32), *_points(32))
    _checkpoint(model_weights, tmp_path / "maps.pt", input_mode="map")
    other = _checkpoint(model_weights, tmp_path / "base2.pt", merged_weights="maps")
    with pytest.raises(NdrqlError, match="the companion maps.pt of base2.pt has input mode map, the base grid") as err:
        Predictor.load(other, threads=1, backend="torch").predict_view(_grid(32), *_points(32))
    assert "\n" not in str(err.value)


def test_a_companion_sees_the_grids_it_serves_through_its_own_view(model_weights, tmp_path):
    """A specialist trained under another view (here ``cap:64``: the 32-cell grid at 2 px per cell, nothing
    merged) serves the grids the base's view merges, through its own view."""
    pytest.importorskip("torch")
    fine = _checkpoint(model_weights, tmp_path / "fine.pt", scale=0.9, view="cap:64")
    base = _checkpoint(model_weights, tmp_path / "base.pt", merged_weights="fine")
    b, c = (Predictor.load(w, threads=1, backend="torch") for w in (base, fine))
    assert str(c.view) == "cap:64" and b.serving(32).view == c.view
    assert _same(_all(b, 32), _all(c, 32)) and b.predict_view(_grid(32), *_points(32)).seen.px == 2


def test_digests_cover_the_companion_and_cache_entries_never_cross(model_weights, tmp_path):
    """The tables' cache: the base's digest covers its companion; an entry made with one companion is
    predicted again (and equals the new companion's cells) once the companion file changes."""
    pytest.importorskip("torch")
    from ndrql.io import file_digest
    from ndrql.maps.problem import MapProblem
    from ndrql.pipeline.samples import PredictionCache, Problem

    base = _checkpoint(model_weights, tmp_path / "base.pt", merged_weights="comp")
    comp = _checkpoint(model_weights, tmp_path / "comp.pt", scale=1.5)
    assert weights_digest(comp) == file_digest(comp) and weights_digest(base, comp) != file_digest(base)
    assert Predictor.load(base, threads=1, backend="torch").weights_digest == weights_digest(base, comp)
    blocked = _grid(32)
    s, g = _points(32)
    p = Problem("hand", 0, "", MapProblem(np.kron(blocked, np.ones((4, 4), bool)), (6, 6), (121, 121)), blocked, s, g, 0)
    first = PredictionCache(tmp_path / "c", base)
    got = first.attach(p)
    own = Predictor.load(comp, threads=1, backend="torch").predict_cells(blocked, s, g)
    assert np.array_equal(got.region, np.clip(own[0].astype(np.float16).astype(np.float64), 0, 1))
    _checkpoint(model_weights, comp, scale=0.5)  # another companion under the same name
    second = PredictionCache(tmp_path / "c", base)
    assert second.digest != first.digest
    again = second.attach(p)
    assert second.computed == 1 and not np.array_equal(again.region, got.region)
    own = Predictor.load(comp, threads=1, backend="torch").predict_cells(blocked, s, g)
    assert np.array_equal(again.region, np.clip(own[0].astype(np.float16).astype(np.float64), 0, 1))
    assert PredictionCache(tmp_path / "c", comp).digest not in (first.digest, second.digest)


def test_plan_names_the_weights_file_that_served(model_weights, tmp_path, capsys):
    pytest.importorskip("torch")
    from ndrql.cli import main

    base = _checkpoint(model_weights, tmp_path / "base.pt", merged_weights="comp")
    comp = _checkpoint(model_weights, tmp_path / "comp.pt", scale=1.5)
    obstacles = np.kron(_grid(16), np.ones((8, 8), bool))  # a 128 px map: a wall with a gap
    for size, served in ((16, base), (32, comp)):
        report = ndrql.solve(obstacles, (8, 8), (120, 120), methods=["NDR-QL"], seeds=[0], weights=base,
                             backend="torch", size=size, workers=1, predict_budget=None)  # a cold torch load
        out = report.to_dict()
        assert out["model_input"]["weights_file"] == served.name and out["weights"] == str(served)
        assert out["model_input"]["companion"] is (served == comp)
    np.save(tmp_path / "map.npy", obstacles)
    plan = ["plan", str(tmp_path / "map.npy"), "--start", "8,8", "--goal", "120,120", "--weights", str(base),
            "--backend", "torch", "--size", "32", "--method", "NDR-QL", "--workers", "1", "--predict-budget", "none"]
    rc = main([*plan, "--json", str(tmp_path / "out.json")])
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("model:"))
    assert rc == 0 and "comp.pt" in line and "the companion of base.pt for the grids its view merges" in line
    assert json.loads((tmp_path / "out.json").read_text())["model_input"]["weights_file"] == "comp.pt"
    comp.unlink()
    rc = main(plan)
    err = capsys.readouterr().err
    assert rc != 0 and "missing companion weights" in err and "Traceback" not in err


def test_export_weights_sets_and_clears_the_companion(model_weights, tmp_path):
    pytest.importorskip("torch")
    from ndrql.errors import CheckpointError
    from ndrql.model.checkpoint import export_weights, load_checkpoint
    from ndrql.model.weights import resolve_weights

    src = _checkpoint(model_weights, tmp_path / "src.pt")
    out = export_weights(src, tmp_path / "with.pt", merged_weights="ndr_general_large")
    assert load_checkpoint(out)["config"]["merged_weights"] == "ndr_general_large"
    kept = export_weights(out, tmp_path / "kept.pt")
    assert load_checkpoint(kept)["config"]["merged_weights"] == "ndr_general_large"
    cleared = export_weights(out, tmp_path / "cleared.pt", merged_weights="")
    assert load_checkpoint(cleared)["config"] == load_checkpoint(src)["config"]
    with pytest.raises(CheckpointError, match="coarse or walls view"):
        export_weights(resolve_weights("paper"), tmp_path / "p.pt", merged_weights="x")
    with pytest.raises(CheckpointError, match="coarse or walls view"):
        export_weights(src, tmp_path / "n.pt", view="native", merged_weights="x")
    for bad in ("a/b", "x.pt", ".."):
        with pytest.raises(NdrqlError, match="file stem"):
            check_stem(bad)
