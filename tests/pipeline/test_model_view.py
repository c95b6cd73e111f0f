"""A grid-mode model predicts through the view it was trained under (its config's ``view``,
:mod:`ndrql.dataset.views`): ``native`` (today's shipped models) is today's prediction bit for bit;
``coarse`` merges a large grid before the model sees it and brings every output back per planning cell,
on the torch path, the ONNX path and through ``plan``."""

from __future__ import annotations

import json

import numpy as np
import pytest

import ndrql
from ndrql.dataset.encodings import encode_input
from ndrql.dataset.render import DISTANCE_UNIT, cell_means, grid_input, manhattan_pixels, merge_cells
from ndrql.dataset.views import GridView
from ndrql.errors import NdrqlError
from ndrql.maps.bundled import bundled_sample
from ndrql.model.onnx_backend import CONFIG_KEY, onnx_available
from ndrql.model.predict import Predictor, config_view
from ndrql.model.symmetry import averaged


def _todays_cells(predictor: Predictor, blocked: np.ndarray, s, g) -> tuple[np.ndarray, ...]:
    """Per-cell region, guideline and distance as ``plan`` computed them before views (grid at 4 px per
    cell, the symmetry average, Manhattan plus the detour, exact 4x4 means)."""
    img, s_px, g_px = grid_input(blocked, s, g, max(blocked.shape))
    r, gl, d = averaged(predictor._runner, encode_input(img, s_px, g_px, predictor.encoding)[None], predictor.symmetries)
    dist = manhattan_pixels(g_px, img.shape[0]) + DISTANCE_UNIT * d[0]
    return tuple(cell_means(a, blocked.shape) for a in (r[0], gl[0], dist))


def _coarse_checkpoint(model_weights, path, view: str):
    """The shipped checkpoint saved again with ``view`` in its model config (as ``ndrql train --view`` records it)."""
    from ndrql.model.checkpoint import load_checkpoint, save_checkpoint

    data = load_checkpoint(model_weights)
    payload = {k: v for k, v in data.items() if k not in ("format", "format_version", "ndrql_version")}
    shipped = {k: v for k, v in dict(data["config"]).items() if k != "merged_weights"}  # no companion beside the copy
    payload["config"] = {**shipped, "view": view}
    return save_checkpoint(path, payload)


@pytest.fixture(scope="module")
def sample():
    return bundled_sample()


def test_config_view_reads_the_models_config():
    assert config_view({}) == GridView() and config_view({"view": None}) == GridView()
    assert config_view({"view": "coarse:128"}) == GridView("coarse", 128)
    assert config_view({"view": "cap:512"}) == GridView("cap", 512)
    with pytest.raises(NdrqlError, match="view"):
        config_view({"view": "tiles:4"})


@pytest.mark.parametrize("backend", ["onnx", "torch"])
def test_native_view_is_todays_prediction_bit_for_bit(model_weights, sample, backend):
    """The shipped general weights (served under ``coarse:128``, native up to 128 cells) on the bundled map's
    grid of at most 128 cells: per-cell arrays, the 4 px arrays and the map-resolution prediction equal what
    plan computed before views, to the last bit, with symmetry averaging."""
    if backend == "onnx" and not onnx_available():
        pytest.skip("onnxruntime not installed")
    if backend == "torch":
        pytest.importorskip("torch")
    plain = Predictor.load(model_weights, threads=1, backend=backend)
    assert plain.input_mode == "grid" and plain.view in (GridView(), GridView("coarse", 128))
    two = plain.with_symmetries(2)
    assert two.view == plain.view and two.symmetries == 2
    pred = two.predict(sample.grid_map.obstacles, sample.start, sample.goal)
    g = pred.grid
    assert plain.view.factor(max(g.blocked.shape)) == 1  # the view is native at this size
    before = _todays_cells(two, g.blocked, g.start, g.goal)
    for got, want in zip(two.predict_cells(g.blocked, g.start, g.goal), before):
        assert got.dtype == np.float64 and np.array_equal(got, want)
    for got, want in zip((g.region, g.guideline, g.distance), before):
        assert np.array_equal(got, want)
    for px, want in zip(two.predict_grid_all(g.blocked, g.start, g.goal), before):
        assert px.shape == (4 * max(g.blocked.shape),) * 2 and np.array_equal(cell_means(px, g.blocked.shape), want)


def test_coarse_view_merges_the_grid_and_spreads_back(model_weights, sample, tmp_path):
    """``coarse:32`` on a 64-cell grid: the model sees the 2x2-merged grid at 4 px per merged cell (128 px);
    every planning cell takes its merged cell's region, guideline and distance (in planning cells), which
    are the native model's on the merged grid."""
    pytest.importorskip("torch")
    from ndrql.maps.sizing import safe_grid

    ckpt = _coarse_checkpoint(model_weights, tmp_path / "coarse.pt", "coarse:32")
    coarse = Predictor.load(ckpt, threads=1, backend="torch")
    assert coarse.view == GridView("coarse", 32) and coarse.with_symmetries(2).view == coarse.view
    pg = safe_grid(sample.grid_map.obstacles, 64, sample.start, sample.goal)
    blocked, s, g = pg.blocked, pg.start, pg.goal
    assert blocked.shape == (64, 64)
    out = coarse.predict_view(blocked, s, g)
    assert out.seen.image.shape == (128, 128) and out.seen.factor == 2 and out.seen.px == 4
    for a in (out.region, out.guideline, out.distance):
        assert a.shape == (64, 64)
        assert np.array_equal(a, np.kron(a[::2, ::2], np.ones((2, 2))))  # constant over each merged 2x2 block
    assert out.region.max() > 0.5 and out.region.min() < 0.5  # a real prediction, not a flat field
    native = Predictor.load(model_weights, threads=1, backend="torch")
    r, gl, d = native.predict_cells(merge_cells(blocked, 2), (s[0] // 2, s[1] // 2), (g[0] // 2, g[1] // 2))
    assert np.array_equal(out.region[::2, ::2], r) and np.array_equal(out.guideline[::2, ::2], gl)
    assert np.allclose(out.distance[::2, ::2], 2 * d, rtol=1e-12)
    px = coarse.predict_grid_all(blocked, s, g)
    assert px[0].shape == (256, 256) and np.allclose(cell_means(px[0], blocked.shape), out.region, atol=1e-12)


def test_prediction_cache_keeps_a_merged_views_cells(model_weights, sample, tmp_path):
    """The tables' prediction cache with a ``coarse`` model on a grid it merges: the entry holds one value per
    planning cell (mode ``cells``), and the priors, the goal distance and the map-resolution arrays are those
    of the 4 px drawing the cache stored before, bit for bit, fresh and read back."""
    pytest.importorskip("torch")
    from ndrql.dataset.render import to_map_pixels
    from ndrql.maps.problem import MapProblem
    from ndrql.maps.sizing import safe_grid
    from ndrql.pipeline.samples import PredictionCache, Problem

    ckpt = _coarse_checkpoint(model_weights, tmp_path / "coarse.pt", "coarse:32")
    pg = safe_grid(sample.grid_map.obstacles, 64, sample.start, sample.goal)
    p = Problem("hand", 0, "", MapProblem(sample.grid_map.obstacles, sample.start, sample.goal), pg.blocked,
                pg.start, pg.goal, 0)
    cache = PredictionCache(tmp_path / "c", ckpt)
    fresh = cache.attach(p)
    with np.load(cache.path(p)) as d:
        assert str(d["mode"]) == "cells" and d["region"].shape == (64, 64)
    again = PredictionCache(tmp_path / "c", ckpt).attach(p)
    r, gl, dist = Predictor.load(ckpt, threads=1, backend="torch").predict_grid_all(p.blocked, p.start, p.goal)
    drawn = [np.asarray(a).astype(np.float16).astype(np.float32) for a in (r, gl)]  # as stored before
    before = [np.clip(cell_means(a, p.blocked.shape), 0, 1) for a in drawn]
    dist_before = cell_means(np.asarray(dist, np.float32), p.blocked.shape)
    for got in (fresh, again):
        assert np.array_equal(got.region, before[0]) and np.array_equal(got.guideline, before[1])
        assert np.array_equal(got.distance, dist_before)
    full = cache.full(p)
    for a, old in zip(full, drawn):
        assert np.array_equal(a, to_map_pixels(old, p.obstacles.shape, 64).astype(np.float32))


def test_export_weights_sets_the_view_and_keeps_the_weights(model_weights, tmp_path):
    """``ndrql export-weights --view``: the served view changes in the config, not one weight; ``native``
    drops the key; a map-mode model (the paper's) is refused."""
    torch = pytest.importorskip("torch")
    from ndrql.errors import CheckpointError
    from ndrql.model.checkpoint import export_weights, load_checkpoint
    from ndrql.model.weights import resolve_weights

    src = load_checkpoint(model_weights)
    out = load_checkpoint(export_weights(model_weights, tmp_path / "c64.pt", view="coarse:64"))
    assert out["config"] == {**{k: v for k, v in src["config"].items() if k != "view"}, "view": "coarse:64"}
    assert out["model"].keys() == src["model"].keys()
    assert all(torch.equal(out["model"][k], src["model"][k].half() if src["model"][k].is_floating_point() else src["model"][k])
               for k in src["model"])
    assert "view" not in load_checkpoint(export_weights(tmp_path / "c64.pt", tmp_path / "n.pt", view="native"))["config"]
    with pytest.raises(CheckpointError, match="grid-mode"):
        export_weights(resolve_weights("paper"), tmp_path / "p.pt", view="coarse:64")
    with pytest.raises(NdrqlError, match="view must be"):
        export_weights(model_weights, tmp_path / "x.pt", view="tiles")


def load_config_view(path):
    """The view recorded in the checkpoint at ``path`` (``None`` when it has none: native)."""
    from ndrql.model.checkpoint import load_checkpoint

    return dict(load_checkpoint(path)["config"]).get("view")


def test_onnx_graph_carries_the_view(model_weights, tmp_path):
    """An ONNX graph's metadata holds the whole model config (``ndrql export-onnx`` copies it unfiltered), so a
    graph of a model trained under ``coarse:32`` loads with that view."""
    if not onnx_available():
        pytest.skip("onnxruntime not installed")
    onnx = pytest.importorskip("onnx")
    graph = onnx.load(str(model_weights.with_suffix(".onnx")))
    props = {p.key: p.value for p in graph.metadata_props}
    config = json.loads(props[CONFIG_KEY])
    assert config.get("view") == load_config_view(model_weights)  # the graph serves the checkpoint's view
    shipped = {k: v for k, v in config.items() if k != "merged_weights"}  # no companion beside the copy
    props[CONFIG_KEY] = json.dumps({**shipped, "view": "coarse:32"}, sort_keys=True)
    del graph.metadata_props[:]
    onnx.helper.set_model_props(graph, props)
    path = tmp_path / "coarse.onnx"
    onnx.save(graph, str(path))
    loaded = Predictor.load(path, threads=1, backend="onnx")
    assert loaded.backend_name == "onnx" and loaded.view == GridView("coarse", 32)
    blocked = np.zeros((40, 40), bool)
    assert loaded.predict_view(blocked, (1, 1), (38, 38)).seen.image.shape == (80, 80)


def test_plan_uses_the_view_and_says_so(model_weights, sample, tmp_path):
    """``plan`` with a coarse checkpoint: the model saw the merged grid (JSON ``model_input``), the run reports
    a path on the map without collision, and the summary line names the view."""
    pytest.importorskip("torch")
    from ndrql.dataset.views import view_note

    ckpt = _coarse_checkpoint(model_weights, tmp_path / "coarse.pt", "coarse:32")
    report = ndrql.solve(sample.grid_map, sample.start, sample.goal, methods=["NDR-QL"], seeds=[0], weights=ckpt,
                         backend="torch", size=64, workers=1)
    seen = report.to_dict()["model_input"]
    assert seen["view"] == "coarse:32" and seen["merged"] == 2 and seen["side"] == 128
    run = report.results[0]
    assert run.path and run.success and not run.collisions
    assert report.grid.shape == (64, 64)
    assert view_note(seen["view"], seen["merged"]) == ", view coarse:32, 2x2 cells seen as one"
    assert view_note(seen["view"], seen["merged"], " through the view ") == " through the view coarse:32, 2x2 cells seen as one"


def test_view_note_names_the_view_only_where_the_model_sees_the_grid_otherwise():
    """One rule for ``plan``'s summary and ``predict``'s: nothing for ``native`` or a ``coarse`` view that merges
    nothing; the view for ``cap`` (it shrinks cells) and for a ``coarse`` view that merges cells."""
    from ndrql.dataset.views import view_note

    assert view_note("native", 1) == "" and view_note("coarse:128", 1) == ""
    assert view_note("cap:512", 1) == ", view cap:512"
    assert view_note("coarse:128", 3, " through the view ") == " through the view coarse:128, 3x3 cells seen as one"
