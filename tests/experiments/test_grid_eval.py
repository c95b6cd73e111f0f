"""F1 of grid-mode models on the paper's splits (ndrql.experiments.grid_eval, ``ndrql eval``)."""

from __future__ import annotations

import json

import numpy as np

from ndrql.dataset.render import to_map_pixels

from helpers.cli import assert_one_line_error, run_cli


def test_map_pixels_take_their_cells_mean():
    """A 9x9 map on a 2x2 grid: cells of 4.5 px; the centres of pixels 0..3 fall in cell 0, of 4..8 (4.5 on the edge) in cell 1."""
    prob = np.zeros((8, 8))
    prob[:4, :4] = 1.0  # cell (0, 0): mean 1
    prob[:4, 4:] = np.tile([1.0, 0.0], (4, 2))  # cell (0, 1): mean 0.5
    prob[4:, :4] = 0.25  # cell (1, 0)
    out = to_map_pixels(prob, (9, 9), 2)
    assert out.shape == (9, 9)
    assert (out[:4, :4] == 1.0).all() and (out[:4, 4:] == 0.5).all()
    assert (out[4:, :4] == 0.25).all() and (out[4:, 4:] == 0.0).all()
    # a non-square map: cells follow the longer side, the short side has fewer cells
    assert to_map_pixels(np.ones((8, 8)), (9, 4), 2).shape == (9, 4)


def test_eval_scores_a_grid_model_both_ways(ndrql_exe, dataset_root, tmp_path):
    out = tmp_path / "e.json"
    res = run_cli(ndrql_exe, "eval", "--split", "unseen", "--weights", "general", "--limit", "6",
                  "--threads", "1", "--data", str(dataset_root), "--json", str(out))
    assert res.returncode == 0, res.stderr
    data = json.loads(out.read_text())
    assert data["input_mode"] == "grid" and data["grid"] == 50
    row = data["rows"][0]
    assert row["n"] == 6 and 0 <= row["grid_region_f1"] <= 100 and 0 <= row["region_f1"] <= 100
    assert "region F1 (grid labels)" in res.stdout


def test_eval_averages_orientations_as_plan_does(ndrql_exe, dataset_root, tmp_path):
    """--symmetries 4 scores what ndrql plan predicts (4 orientations of the grid averaged): other
    probabilities, so other F1s than the plain forward's, and the JSON and the title say so."""
    rows = {}
    for k in (1, 4):
        out = tmp_path / f"e{k}.json"
        res = run_cli(ndrql_exe, "eval", "--split", "unseen", "--weights", "general", "--limit", "4", "--threads", "1",
                      "--data", str(dataset_root), "--json", str(out), "--symmetries", str(k))
        assert res.returncode == 0, res.stderr
        data = json.loads(out.read_text())
        assert data["symmetries"] == k and ("averaged over 4 orientations" in res.stdout) == (k == 4)
        rows[k] = data["rows"][0]
    assert rows[1]["n"] == rows[4]["n"] == 4
    assert (rows[1]["grid_region_f1"], rows[1]["grid_guideline_f1"]) != (rows[4]["grid_region_f1"], rows[4]["grid_guideline_f1"])


def test_prediction_cache_asks_a_grid_model_on_the_planning_grid(dataset_root, tmp_path):
    """The tables' prediction cache: a grid-mode model predicts on the problem's own planning grid; its
    priors are the 4x4 cell means; the second call reads the cache and gives the same arrays."""
    from ndrql.pipeline.samples import PredictionCache, load_problem

    p = load_problem(dataset_root, "seen", 0)
    cache = PredictionCache(tmp_path, "general")
    a = cache.attach(p)
    assert a.region.shape == p.blocked.shape == a.guideline.shape and cache.computed == 1
    assert 0 <= a.region.min() and a.region.max() <= 1
    assert a.region[p.start] > 0.5 and a.region[p.goal] > 0.5  # the region holds both ends of the path
    b = PredictionCache(tmp_path, "general").attach(p)
    assert np.array_equal(a.region, b.region) and np.array_equal(a.guideline, b.guideline)
    region_map, _ = cache.full(p)
    assert region_map.shape == p.obstacles.shape


def test_prediction_cache_turns_only_a_grid_model_and_names_it(dataset_root, tmp_path):
    """Averaged over 4 orientations (plan's default) the grid model's priors differ from the plain
    forward's, and the digest that goes into task fingerprints says so; the paper's map-mode model is
    never turned, so its digest and predictions stay those of earlier runs."""
    from ndrql.pipeline.samples import PredictionCache, load_problem

    p = load_problem(dataset_root, "seen", 0)
    plain, four = PredictionCache(tmp_path / "1", "general"), PredictionCache(tmp_path / "4", "general", symmetries=4)
    assert four.digest == plain.digest + "-s4" and four.symmetries == 4
    a, b = plain.attach(p), four.attach(p)
    assert not np.array_equal(a.region, b.region)
    paper = PredictionCache(tmp_path / "p", "paper", symmetries=4)
    assert paper.symmetries == 1 and len(paper.digest) == 16


def test_eval_prior_from_oracle_scores_the_grids_own_labels(ndrql_exe, dataset_root, tmp_path):
    """The oracle's arrays are the grid's labels: 100 against those, less against the dataset's (the ceiling
    of a prediction on the 50x50 grid); no weights are named, 'oracle priors' is."""
    out, md = tmp_path / "o.json", tmp_path / "o.md"
    res = run_cli(ndrql_exe, "eval", "--split", "unseen", "--prior-from", "oracle", "--limit", "6",
                  "--data", str(dataset_root), "--json", str(out), "--markdown", str(md))
    assert res.returncode == 0, res.stderr
    data = json.loads(out.read_text())
    assert data["weights"] == "oracle priors" and data["prior_from"] == "oracle" and data["grid"] == 50
    row = data["rows"][0]
    assert row["n"] == 6 and row["grid_region_f1"] == row["grid_guideline_f1"] == 100.0
    assert 50 < row["region_f1"] < 100 and 0 < row["guideline_f1"] < 100
    assert "oracle priors" in res.stdout and ".pt" not in res.stdout and md.read_text() in res.stdout


def test_eval_prior_from_oracle_bad_combinations(ndrql_exe, tmp_path):
    r = run_cli(ndrql_exe, "eval", "--prior-from", "oracle", "--weights", "paper")
    assert_one_line_error(r, "give either --weights or --prior-from oracle, not both")
    r = run_cli(ndrql_exe, "eval", "--prior-from", "oracle", "--split", "val")
    assert_one_line_error(r, "with --prior-from oracle use seen or unseen")
    r = run_cli(ndrql_exe, "eval", "--prior-from", "oracle", "--symmetries", "4")
    assert_one_line_error(r, "the oracle's arrays are not predicted")
