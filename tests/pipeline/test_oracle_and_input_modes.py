"""Oracle priors through the API and the CLI, and models that see the planning grid (grid input mode)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import ndrql
from ndrql.maps.grid import area_downscale
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.preset import load_preset
from ndrql.synth.oracle import oracle_prediction

from helpers.cli import assert_one_line_error, run_cli


def _walls() -> np.ndarray:
    grid = np.zeros((120, 160), dtype=bool)
    grid[40:46, :120] = True
    grid[80:86, 40:] = True
    return grid


def test_api_oracle_priors_are_the_grids_own_path():
    report = ndrql.solve(_walls(), (10, 10), (110, 150), methods=["NDR-QL"], seeds=[0], predictions="oracle", workers=1)
    assert report.weights == "oracle priors" and report.info["prior_from"] == "oracle"
    pg = report.grid
    region, guide = oracle_prediction(pg.blocked, pg.start, pg.goal, 4)
    h, w = pg.shape
    # the priors were built from exactly the oracle's 4x4 block means on the grid
    from ndrql.planning.methods import build_priors

    expect = build_priors("NDR-QL", pg.blocked, pg.start, pg.goal, area_downscale(region[:4 * h, :4 * w], (h, w)),
                          area_downscale(guide[:4 * h, :4 * w], (h, w)), report.prior_config)
    assert report.thresholds["NDR-QL"] == expect.threshold
    assert report.results[0].converged
    assert report.to_dict()["weights"] == "oracle priors"


def test_cli_prior_from_oracle_is_named_in_output_and_json(tmp_path, ndrql_exe):
    np.save(tmp_path / "m.npy", _walls())
    out = run_cli(ndrql_exe, "plan", str(tmp_path / "m.npy"), "--start", "10,10", "--goal", "110,150",
                  "--prior-from", "oracle", "--json", str(tmp_path / "o.json"))
    assert out.returncode == 0, out.stderr
    assert "oracle priors" in out.stdout
    d = json.loads((tmp_path / "o.json").read_text())
    assert d["weights"] == "oracle priors" and d["prior_from"] == "oracle" and d["model_input"]["oracle"] is True


@pytest.fixture(scope="module")
def grid_model(tmp_path_factory):
    """A tiny model trained two steps in grid mode (enough to carry input_mode=grid in its checkpoint)."""
    from ndrql.dataset.generated import generate_set
    from ndrql.synth.generate import SetSpec
    from ndrql.training.config import TrainConfig
    from ndrql.training.loop import train

    root = tmp_path_factory.mktemp("gm")
    generate_set(root / "set", SetSpec(("blocks",), (96,), 8, 1), progress=False, shard_size=8)
    cfg = TrainConfig(sources=f"{root / 'set'}:1", input_mode="grid", grid_sizes="16", model_overrides={"width": 0.25},
                      batch_size=2, epochs=1, steps_per_epoch=2, warmup_steps=1, bf16=False, threads=1, val_per_source=1)
    train(cfg, root / "run", progress=False, log=lambda m: None)
    return root / "run" / "last.pt"


def test_grid_mode_model_predicts_on_the_planning_grid(grid_model):
    from ndrql.model.onnx_backend import onnx_available
    from ndrql.model.predict import Predictor
    from ndrql.pipeline.predictions import predict_region

    torch_pred = Predictor.load(grid_model, threads=1, backend="torch")
    assert torch_pred.input_mode == "grid"
    report = ndrql.solve(_walls(), (10, 10), (110, 150), methods=["NDR-QL"], seeds=[0], weights=grid_model, workers=1,
                         fallback=None, predict_budget=None)  # a fresh checkpoint's first load: no time budget
    pg = report.grid
    view = predict_region(torch_pred, report.grid_map, pg, report.start, report.goal)
    assert view.info["mode"] == "grid" and view.info["side"] == 4 * max(pg.shape)
    assert view.region_grid.shape == pg.shape and view.region.shape == report.grid_map.shape
    assert 0.0 <= view.region_grid.min() and view.region_grid.max() <= 1.0
    if onnx_available():  # the ONNX path exports one graph for every input side; it agrees with torch
        onnx_pred = Predictor.load(grid_model, threads=1, backend="onnx")
        assert onnx_pred.input_mode == "grid"
        other = predict_region(onnx_pred, report.grid_map, pg, report.start, report.goal)
        assert np.allclose(other.region_grid, view.region_grid, atol=1e-3)


@pytest.mark.slow
def test_reproduce_transfer_end_to_end(tmp_path, ndrql_exe, monkeypatch):
    """A tiny transfer report: every family of the small set at grid 32, 2 seeds; model, oracle and share columns."""
    import os

    env = {**os.environ, "NDRQL_CACHE": str(tmp_path / "cache")}
    out = run_cli(ndrql_exe, "reproduce", "transfer", "--eval-set", "transfer-small", "--grids", "32", "--seeds", "2",
                  "--per-family", "1", "--workers", "1", "--executor", "serial", "--no-progress",
                  "--preset", "spec,tuned", "--no-learned-distance", "--out", str(tmp_path / "tr"), env=env)
    assert out.returncode == 0, out.stderr
    # each preset into its own folder; with tuned, every row runs its method's constants
    tuned = json.loads((tmp_path / "tr-tuned" / "summary.json").read_text())
    assert tuned["preset"] == "tuned" and "constants of preset 'tuned'" in (tmp_path / "tr-tuned" / "transfer.md").read_text()
    at32 = tuned["constants"]["32"]  # the constants of each grid size the report planned on
    assert at32["QL (tuned)"]["ql"] == vars(load_preset("tuned").configs("QL")[0])  # grid 32: the nearest, 50
    assert at32["QL"]["ql"] == vars(QLConfig())  # the paper's QL whatever the preset
    assert at32["NDR-QL (oracle)"] == at32["NDR-QL (model)"] != at32["QL"]
    assert at32["IQL (BFS distance)"] == at32["IQL"]
    text = (tmp_path / "tr" / "transfer.md").read_text()
    assert "| **all** |" in text and "share of oracle" in text and "Planning grid 32" in text
    assert "![predictions](transfer_predictions.png)" in text
    assert (tmp_path / "tr" / "transfer_predictions.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = json.loads((tmp_path / "tr" / "summary.json").read_text())
    assert summary["preset"] == "spec" and "the paper's constants" in text
    assert summary["learned_distance"] is False and "Eq. 6 on the straight line, the paper's" in text
    assert all(c == {"ql": vars(QLConfig()), "priors": vars(PriorConfig())} for row, c in summary["constants"]["32"].items()
               if row != "QL (tuned)")  # the tuned QL row takes searched constants whatever the preset
    done = [r for r in summary["records"] if not r["skipped"]]
    assert done and all(len(r["runs"]["QL"]["steps"]) == 2 for r in done)
    # the share divides reductions of the same runs: recompute it from the records
    from ndrql.experiments.transfer_report import summarize

    s = summarize(summary["records"])
    ql = sum(sum(r["runs"]["QL"]["steps"]) for r in done)
    red = lambda row: 1 - sum(sum(r["runs"][row]["steps"]) for r in done) / ql  # noqa: E731
    assert abs(s["share"] - red("NDR-QL (model)") / red("NDR-QL (oracle)")) < 1e-12
    bad = run_cli(ndrql_exe, "reproduce", "transfer", "--eval-set", "nope", "--out", str(tmp_path / "x"), env=env)
    assert_one_line_error(bad, "valid: transfer")


@pytest.mark.filterwarnings("ignore::ndrql.planning.priors.ThresholdWarning")  # the region is checked, not the runs
def test_a_grid_mode_model_predicts_on_the_safe_grid_plan_builds(model_weights):
    """Predictor.predict with a grid-mode model: the safe grid of the size plan's --size auto picks (or the
    given size), start and goal placed as plan places them; each map pixel holds its cell's mean, and
    the per-cell arrays are the 4x4 means of the model's output on exactly that grid."""
    from ndrql.dataset.render import cell_means
    from ndrql.maps.safe import conservative_grid
    from ndrql.model.predict import load_predictor
    from ndrql.pipeline.settings import PlanSettings

    predictor = load_predictor(model_weights, symmetries=PlanSettings().symmetries)  # as plan loads it
    if predictor.input_mode != "grid":
        pytest.skip(f"{model_weights} holds a map-mode model")
    m = _walls()
    report = ndrql.solve(m, (10, 10), (110, 150), methods=["NDR-QL"], seeds=[0], workers=1, fallback=None,
                         predictions="model")  # a known map takes the exact prior unless the model is named
    auto = predictor.predict(m, (10, 10), (110, 150))
    assert auto.grid.size == report.setup.size and np.array_equal(auto.grid.blocked, report.grid.blocked)
    assert (auto.grid.start, auto.grid.goal) == (report.grid.start, report.grid.goal)
    assert np.array_equal(auto.region, report.region) and np.array_equal(auto.guideline, report.guideline)
    pred = predictor.predict(m, (10, 10), (110, 150), size=40)
    g = pred.grid
    assert g.size == 40 and np.array_equal(g.blocked, conservative_grid(m, 40))
    r, gl = predictor.predict_grid(g.blocked, g.start, g.goal)
    assert np.array_equal(g.region, cell_means(r, g.blocked.shape)) and np.array_equal(g.guideline, cell_means(gl, g.blocked.shape))
    cell = 160 / 40  # 4 px cells on this 120x160 map
    for (i, j) in ((0, 0), (57, 101), (119, 159)):
        assert pred.region[i, j] == g.region[int((i + 0.5) / cell), int((j + 0.5) / cell)]
        assert pred.guideline[i, j] == g.guideline[int((i + 0.5) / cell), int((j + 0.5) / cell)]


def test_prediction_files_with_broken_grid_arrays_are_one_line_errors(ndrql_exe, tmp_path):
    """A prediction file with some grid arrays but not all, or grid arrays of mismatched shapes: one line, exit 2."""
    m = _walls()
    np.save(tmp_path / "m.npy", m)
    region = np.full(m.shape, 0.5)
    grid = {"grid_size": np.array(40), "grid_blocked": np.zeros((30, 40), bool), "grid_start": np.array([2, 2]),
            "grid_goal": np.array([27, 37]), "grid_region": np.zeros((30, 40)), "grid_guideline": np.zeros((30, 40))}
    cases = {"partial": ({k: v for k, v in grid.items() if k != "grid_guideline"}, "not grid_guideline"),
             "shapes": ({**grid, "grid_region": np.zeros((3, 4))}, "one 2-D shape"),
             "range": ({**grid, "grid_region": np.full((30, 40), 2.0)}, "probabilities in [0, 1]")}
    for name, (extra, needle) in cases.items():
        np.savez(tmp_path / f"{name}.npz", region=region, guideline=region, **extra)
        r = run_cli(ndrql_exe, "plan", tmp_path / "m.npy", "--start", "10,10", "--goal", "110,150", "--seeds", "1",
                    "--prior-from", tmp_path / f"{name}.npz")
        assert_one_line_error(r, needle)
    r = run_cli(ndrql_exe, "predict", tmp_path / "m.npy", "--start", "10,10", "--goal", "110,150", "--size", "1",
                "--out", tmp_path / "p")
    assert_one_line_error(r, "--size must be an integer in 2..1,024")  # every command's bounds
    assert not (tmp_path / "p").exists()
    cut = np.zeros((100, 100), bool)
    cut[50, :] = True  # no grid joins the two halves: the grid-mode model has nothing to predict on
    np.save(tmp_path / "cut.npy", cut)
    r = run_cli(ndrql_exe, "predict", tmp_path / "cut.npy", "--start", "10,10", "--goal", "90,90", "--out", tmp_path / "q",
                "--weights", "general")
    assert_one_line_error(r, "not connected")
    assert not (tmp_path / "q").exists()
