"""Eq. 6's distance through the region (``region_distance``) end to end: one request, one answer from the CLI
and the API, said in the JSON and the summary, refused in one line when out of range."""

from __future__ import annotations

import json

import numpy as np
import pytest

import ndrql
from ndrql.pipeline.settings import PlanSettings
from ndrql.planning import priors as P

from helpers import REPO_ROOT, two_walls
from helpers.cli import assert_one_line_error, run_cli



@pytest.fixture(scope="module")
def walls_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("rd") / "walls.npy"
    np.save(path, two_walls())
    return path


SAMPLE = REPO_ROOT / "src" / "ndrql" / "data" / "sample_map.png"
START, GOAL = (25, 179), (167, 5)


def test_cli_and_api_give_the_same_run_and_say_which_distance(tmp_path, ndrql_exe):
    out = tmp_path / "plan.json"
    r = run_cli(ndrql_exe, "plan", SAMPLE, "--start", "25,179", "--goal", "167,5", "--region-distance", "1",
                "--prior-from", "model", "--json", out)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "Eq. 6's distance: moves through the region (NDR-QL), the model elsewhere" in r.stdout
    cli = json.loads(out.read_text())
    assert cli["qi_distance"] == "moves through the region (NDR-QL), the model elsewhere"
    assert cli["prior_config"]["region_distance"] == 1
    api = ndrql.solve(str(SAMPLE), START, GOAL, priors={"region_distance": 1}, predictions="model")
    assert api.info["qi_distance"] == cli["qi_distance"] and api.prior_config.region_distance == 1
    run = api.results[0]
    assert run.method == "NDR-QL" and run.converged
    assert [run.convergence_steps, run.path_length] == [cli["runs"][0]["convergence_steps"], cli["runs"][0]["path_length"]]
    plain = ndrql.solve(str(SAMPLE), START, GOAL, priors={"region_distance": 0}, predictions="model")
    assert plain.info["qi_distance"] == "model" and plain.prior_config.region_distance == 0
    assert plain.thresholds == api.thresholds  # the same region and threshold; only Eq. 6's distance differs


def test_no_threshold_says_the_distance_that_was_used(walls_file):
    # on these walls the model's region joins start and goal at no threshold of NDR-QL's schedule (without the
    # schedule's tail, which would reach the low threshold): the judge rejects it, and kept anyway (fallback none)
    # the mask is 0 everywhere, nothing is counted through the region, and the JSON does not claim it was
    report = ndrql.solve(str(walls_file), (10, 10), (110, 150), priors={"region_distance": 1, "thd_tail": 0},
                         settings=PlanSettings(fallback=None), predictions="model")
    assert report.thresholds["NDR-QL"] is None and not report.info["prediction_quality"]["informative"]
    assert report.info["qi_distance"] == "model"


def test_region_distance_never_below_the_free_space_distance():
    # moves through the region are moves through free space: never fewer than the grid's BFS distance
    from ndrql.maps.grid import bfs_distances
    from ndrql.planning.methods import downscale_priors

    report = ndrql.solve(str(SAMPLE), START, GOAL, priors={"region_distance": 1}, predictions="model")
    pg, thd = report.grid, report.thresholds["NDR-QL"]
    region, _ = downscale_priors(report.region, report.guideline, pg.shape)
    free = bfs_distances(pg.blocked, pg.goal)
    through = P.region_distance(pg.blocked, region, thd, pg.goal, np.full(pg.shape, 1e9))
    inside = through < 1e9
    assert inside[pg.start] and inside.sum() > 50
    assert np.all(through[inside] >= free[inside])


@pytest.mark.parametrize("value", ["2", "-1", "0.5", "nan"])
def test_out_of_range_is_one_line_exit_2(walls_file, tmp_path, ndrql_exe, value):
    out = tmp_path / "plan.json"
    r = run_cli(ndrql_exe, "plan", walls_file, "--start", "10,10", "--goal", "110,150", "--region-distance", value,
                "--json", out)
    assert_one_line_error(r, "--region-distance")
    assert not out.exists()


def test_the_general_preset_counts_through_the_region_at_every_grid(tmp_path, ndrql_exe):
    # the shipped general preset: its grid-128 entry (every grid above 113 cells) has region_distance 1, and so
    # (since their own check) do the entries for grids 50 and 100; CLI and API agree, and a flag turns it off
    out = tmp_path / "plan.json"
    r = run_cli(ndrql_exe, "plan", SAMPLE, "--start", "25,179", "--goal", "167,5", "--size", "128", "--prior-from",
                "model", "--json", out)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "Eq. 6's distance: moves through the region (NDR-QL), the model elsewhere" in r.stdout
    cli = json.loads(out.read_text())
    assert cli["prior_config"]["region_distance"] == 1 and cli["ndr_qi_threshold"]["NDR-QL"] is not None
    api = ndrql.solve(str(SAMPLE), START, GOAL, settings=PlanSettings(size=128), predictions="model")
    assert api.info["qi_distance"] == cli["qi_distance"]
    assert [api.results[0].convergence_steps, api.results[0].path_length] == \
        [cli["runs"][0]["convergence_steps"], cli["runs"][0]["path_length"]]
    off = ndrql.solve(str(SAMPLE), START, GOAL, settings=PlanSettings(size=128), priors={"region_distance": 0},
                      predictions="model")
    assert off.info["qi_distance"] == "model" and off.prior_config.region_distance == 0
    for size in (64, 100):  # at 50 cells the start's cell touches a wall (a SnapWarning)
        small = ndrql.solve(str(SAMPLE), START, GOAL, settings=PlanSettings(size=size), predictions="model")
        assert small.prior_config.region_distance == 1 and small.thresholds["NDR-QL"] is not None
        assert small.info["qi_distance"] == "moves through the region (NDR-QL), the model elsewhere"
    exact = ndrql.solve(str(SAMPLE), START, GOAL, settings=PlanSettings(size=128))  # the default on a known map
    assert exact.prior_config.region_distance == 1 and exact.info["policy"] == ["exact"]
    assert exact.info["qi_distance"] == "moves through the region (NDR-QL), the exact BFS distance elsewhere"


def test_the_fallback_is_the_exact_distance_unless_another_is_named(walls_file, tmp_path, ndrql_exe):
    # where every source is rejected (here a region of zeros given with --prior-from), plan runs IQL-BFS, the exact
    # distance, and says so; --fallback IQL still plans with the straight line
    flat = tmp_path / "flat.npz"
    np.savez(flat, region=np.zeros((120, 160)), guideline=np.full((120, 160), 0.2))
    args = ("plan", walls_file, "--start", "10,10", "--goal", "110,150", "--prior-from", flat)
    r = run_cli(ndrql_exe, *args)
    assert r.returncode == 0, r.stderr[-2000:]
    line = [x for x in r.stdout.splitlines() if x.startswith("prediction: file rejected")]
    assert len(line) == 1 and "NDR-QL fell back to IQL-BFS (the exact BFS distance); --fallback none" in line[0]
    assert "IQL-BFS (fallback for NDR-QL) seed 0: converged" in r.stdout
    r2 = run_cli(ndrql_exe, *args, "--fallback", "IQL")
    assert r2.returncode == 0, r2.stderr[-2000:]
    line = [x for x in r2.stdout.splitlines() if x.startswith("prediction: file rejected")]
    assert len(line) == 1 and line[0].endswith("NDR-QL fell back to IQL; --fallback none keeps the model's priors")
    assert "IQL (fallback for NDR-QL) seed 0: converged" in r2.stdout
