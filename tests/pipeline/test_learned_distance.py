"""A model with a goal-distance head, end to end: its distance reaches Eq. 6 in plan, predict files and ONNX."""

from __future__ import annotations

import json

import numpy as np
import pytest

import ndrql
from ndrql.pipeline.settings import PlanSettings
from ndrql.planning.methods import build_priors

from helpers import two_walls
from helpers.cli import run_cli




@pytest.fixture(scope="module")
def distance_model(tmp_path_factory):
    """A tiny grid-mode model with a distance head (the skips decoder), trained two steps from scratch with
    the snapped ranking loss (v6's)."""
    from ndrql.dataset.generated import generate_set
    from ndrql.synth.generate import SetSpec
    from ndrql.training.config import TrainConfig
    from ndrql.training.loop import train

    root = tmp_path_factory.mktemp("dm")
    generate_set(root / "set", SetSpec(("blocks",), (96,), 40, 1), progress=False, shard_size=20)  # 3% held out: 1
    cfg = TrainConfig(sources=f"{root / 'set'}:1", input_mode="grid", grid_sizes="16", model_overrides={"width": 0.25},
                      batch_size=2, epochs=1, steps_per_epoch=2, warmup_steps=1, bf16=False, threads=1, val_per_source=2,
                      distance_head=True, distance_decoder="skips", distance_rank="raw+snapped")
    train(cfg, root / "run", progress=False, log=lambda m: None)
    rows = (root / "run" / "metrics.csv").read_text().splitlines()
    header, values = rows[0].split(","), dict(zip(rows[0].split(","), rows[1].split(",")))
    assert "distance_order_all" in header  # validation reports how well it orders neighbours, raw and snapped
    assert 0.0 <= float(values["distance_order_snapped_all"]) <= 100.0
    return root / "run" / "last.pt"


def test_plan_uses_the_models_distance_in_eq6(distance_model):
    from ndrql.model.predict import Predictor
    from ndrql.pipeline.predictions import predict_region

    # the learned distance alone: the general preset counts it through the region (tests/pipeline/test_region_distance_plan.py)
    # no time budget: a fresh checkpoint's first load (torch, the ONNX export) may take longer than plan's default
    report = ndrql.solve(two_walls(), (10, 10), (110, 150), methods=["NDR-QL"], seeds=[0], weights=distance_model,
                         workers=1, settings=PlanSettings(fallback=None, predict_budget=None),
                         priors={"region_distance": 0})
    assert report.info["qi_distance"] == "model"
    pg = report.grid
    view = predict_region(Predictor.load(distance_model, threads=1, backend="torch"), report.grid_map, pg,
                          report.start, report.goal)
    assert view.distance_grid is not None and view.distance_grid.shape == pg.shape
    with_d = build_priors("NDR-QL", pg.blocked, pg.start, pg.goal, view.region_grid, view.guideline_grid,
                          report.prior_config, view.distance_grid)
    without = build_priors("NDR-QL", pg.blocked, pg.start, pg.goal, view.region_grid, view.guideline_grid,
                           report.prior_config)
    assert not np.allclose(with_d.q0, without.q0)
    off = ndrql.solve(two_walls(), (10, 10), (110, 150), methods=["NDR-QL"], seeds=[0], weights=distance_model,
                      workers=1, settings=PlanSettings(fallback=None, learned_distance=False, predict_budget=None),
                      priors={"region_distance": 0})
    assert off.info["qi_distance"] == "straight line"
    # predictions without a distance (arrays at the map's resolution): the paper's straight line
    given = ndrql.solve(two_walls(), (10, 10), (110, 150), methods=["NDR-QL"], seeds=[0], workers=1,
                        predictions=(report.region, report.guideline), priors={"region_distance": 0})
    assert given.info["qi_distance"] == "straight line"
    # the oracle carries the true map's BFS distance (pipeline/sources.py)
    oracle = ndrql.solve(two_walls(), (10, 10), (110, 150), methods=["NDR-QL"], seeds=[0], predictions="oracle", workers=1,
                         priors={"region_distance": 0})
    assert oracle.info["qi_distance"] == "true map's BFS distance"


def test_predict_file_carries_the_distance_to_plan(distance_model, tmp_path, ndrql_exe):
    np.save(tmp_path / "m.npy", two_walls())
    common = ("--start", "10,10", "--goal", "110,150")
    out = run_cli(ndrql_exe, "predict", str(tmp_path / "m.npy"), *common, "--weights", str(distance_model),
                  "--backend", "torch", "--out", str(tmp_path / "pred"))
    assert out.returncode == 0, out.stderr
    npz = next((tmp_path / "pred").glob("*.npz"))
    assert (tmp_path / "pred" / "distance.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and "distance.png" in out.stdout
    with np.load(npz) as d:
        assert "grid_distance" in d.files and d["grid_distance"].shape == d["grid_blocked"].shape
    runs = {}
    for name, extra in (("model", ("--weights", str(distance_model), "--backend", "torch")), ("file", ("--prior-from", str(npz)))):
        res = run_cli(ndrql_exe, "plan", str(tmp_path / "m.npy"), *common, *extra, "--fallback", "none",
                      "--json", str(tmp_path / f"{name}.json"))
        assert res.returncode == 0, res.stderr
        runs[name] = json.loads((tmp_path / f"{name}.json").read_text())
        for run in runs[name]["runs"]:
            run.pop("wall_time")
    # the general preset counts Eq. 6's distance through the region; the file's learned distance serves elsewhere
    assert runs["file"]["prior_grid"] == "as given"
    assert runs["file"]["qi_distance"] == runs["model"]["qi_distance"] == "moves through the region (NDR-QL), the model elsewhere"
    assert runs["file"]["runs"] == runs["model"]["runs"]


@pytest.mark.parametrize("decoder", ["trained skips", "coarse"])
def test_onnx_graph_has_the_distance_output(distance_model, tmp_path, decoder):
    pytest.importorskip("onnxruntime")
    pytest.importorskip("onnx")
    import torch

    from ndrql.model.checkpoint import save_checkpoint
    from ndrql.model.export import export_onnx, max_differences
    from ndrql.model.registry import build_model

    weights = distance_model
    if decoder == "coarse":  # the v4 head, untrained: the graph must still match eager
        torch.manual_seed(0)
        cfg = {"arch": "ndr", "encoding": "point", "width": 0.25, "unet_base": 8, "input_mode": "grid", "distance_head": True}
        weights = save_checkpoint(tmp_path / "coarse.pt", {"config": cfg, "model": build_model(cfg).state_dict()})
    graph = export_onnx(weights, tmp_path / "d.onnx")
    diffs = max_differences(weights, graph, sides=(64, 96), count=1)
    assert all(set(d) == {"region", "guideline", "distance"} for d in diffs.values())
    assert max(d["distance"] for d in diffs.values()) < 1e-3


def test_reproduce_prediction_cache_keeps_the_distance(distance_model, tmp_path):
    """The reproduction commands' prediction cache stores the distance (fp32) and hands it to Eq. 6."""
    from ndrql.experiments.planning_runs import plan_task
    from ndrql.maps.astar import astar4
    from ndrql.maps.safe import conservative_grid
    from ndrql.maps.problem import MapProblem
    from ndrql.pipeline.samples import PredictionCache, Problem
    from ndrql.planning.config import PriorConfig, QLConfig
    from ndrql.planning.methods import get_method

    obstacles = two_walls()
    blocked = conservative_grid(obstacles, 40)
    start, goal = (2, 2), (27, 37)
    p = Problem("hand", 0, "walls", MapProblem(obstacles, (10, 10), (110, 150)), blocked, start, goal,
                int(astar4(blocked, start, goal).moves))
    cache = PredictionCache(tmp_path / "c", weights=distance_model)
    first = cache.attach(p)
    again = PredictionCache(tmp_path / "c", weights=distance_model).attach(p)  # from the file this time
    assert first.distance is not None and first.distance.shape == blocked.shape
    assert np.array_equal(first.distance, again.distance) and cache.computed == 1
    with np.load(next((tmp_path / "c").glob("*.npz"))) as d:
        assert d["distance"].dtype == np.float32
    ql = QLConfig(max_episodes=50)
    m = get_method("NDR-QL")
    res = plan_task(blocked, start, goal, m, [0], ql, PriorConfig(), first.region, first.guideline, None, first.distance)
    expect = build_priors(m, blocked, start, goal, first.region, first.guideline, PriorConfig(), first.distance)
    assert not np.allclose(expect.q0, build_priors(m, blocked, start, goal, first.region, first.guideline).q0)
    from ndrql.planning.runner import run_plan

    again_run = run_plan(blocked, start, goal, m, 0, ql, PriorConfig(), priors=expect)
    assert res["threshold"] == expect.threshold
    assert res["runs"][0]["total_steps"] == again_run.total_steps and res["runs"][0]["path"] == [list(c) for c in again_run.path]


def test_shipped_general_model_has_the_distance_head_and_plan_uses_it():
    from ndrql.model.predict import Predictor
    from ndrql.model.weights import shipped_weights

    pred = Predictor.load(shipped_weights("general"), threads=1)
    obstacles = two_walls()
    p = pred.predict(obstacles, (10, 10), (110, 150))
    d = p.grid.distance
    assert d is not None and d.shape == p.grid.blocked.shape and np.isfinite(d).all()
    goal = p.grid.goal
    assert d[goal] < 3  # about 0 at the goal itself
    report = ndrql.solve(obstacles, (10, 10), (110, 150), methods=["NDR-QL"], seeds=[0], workers=1,
                         settings=PlanSettings(fallback=None), preset="spec",  # the paper's threshold search connects here
                         predictions="model")  # a known map takes the exact prior unless the model is named
    assert report.info["qi_distance"] == "model" and report.results[0].converged


def test_plan_averages_over_the_grid_symmetries_it_reports(distance_model, tmp_path, ndrql_exe):
    from helpers.cli import assert_one_line_error

    for k in (1, 4):
        report = ndrql.solve(two_walls(), (10, 10), (110, 150), methods=["NDR-QL"], seeds=[0], weights=distance_model,
                             workers=1, settings=PlanSettings(fallback=None, symmetries=k, backend="torch"))
        assert report.info["symmetries"] == k and report.results[0].total_steps > 0
    assert PlanSettings().symmetries == 1  # one forward pass by default (studies/plan_defaults)
    with pytest.raises(ndrql.api.NdrqlError, match="symmetries must be one of 1, 2, 4, 8, got 3"):
        PlanSettings(symmetries=3)
    np.save(tmp_path / "m.npy", two_walls())
    for cmd in ("plan", "predict"):
        out = run_cli(ndrql_exe, cmd, str(tmp_path / "m.npy"), "--start", "10,10", "--goal", "110,150",
                      "--weights", str(distance_model), "--symmetries", "3", "--out" if cmd == "predict" else "--json",
                      str(tmp_path / f"{cmd}.out"))
        assert_one_line_error(out, "argument --symmetries: invalid choice: 3")
        assert not (tmp_path / f"{cmd}.out").exists()
