"""Honest heuristics: a prediction the judge rejects is named, and the fallback (IQL-BFS by default) plans instead.

The judge's rules on hand-made grids are in test_judge.py; here the same hand-made predictions arrive as a user
gives them (arrays at the map's resolution, a prediction file) and go through the whole plan.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import ndrql
from ndrql.errors import FallbackWarning
from ndrql.maps.grid import GridMap, PlanningGrid, area_downscale
from ndrql.pipeline.judge import judge
from ndrql.pipeline.settings import PlanSettings
from ndrql.pipeline.sources import GivenSource, SourceInput
from ndrql.planning.config import PriorConfig

from helpers.cli import run_cli


def corridor_map() -> np.ndarray:
    """200x200: a wall across row 100 with a gap at cols 150..189."""
    m = np.zeros((200, 200), dtype=bool)
    m[98:102, :150] = True
    m[98:102, 190:] = True
    return m


def good_prediction(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Region: a band round the gap; guideline: a polyline through it on free pixels."""
    region = np.zeros(m.shape)
    region[:, 120:200] = 0.9
    guide = np.zeros(m.shape)
    guide[20:180, 170] = 1.0
    return region, guide


def given_verdict(m: np.ndarray, region: np.ndarray, guide: np.ndarray, start, goal):
    """The judge's verdict on arrays given at the map's resolution, as a plan on a 50-cell grid sees them."""
    grid = PlanningGrid.from_map(m, start, goal, size=50)
    priors = GivenSource((region, guide)).give(SourceInput(grid, GridMap(m), start, goal))
    assert priors.region.shape == grid.blocked.shape and np.allclose(priors.region, area_downscale(region))
    return judge(priors.region, priors.guideline, grid.blocked, grid.start, grid.goal, PriorConfig())


def test_the_judge_on_hand_made_predictions_given_at_the_maps_resolution():
    m = corridor_map()
    region, guide = good_prediction(m)
    v = given_verdict(m, region, guide, (20, 170), (180, 170))
    assert v.accepted and v.threshold == pytest.approx(0.89) and v.guideline_on_obstacles == 0.0
    assert v.route_ratio == pytest.approx(1.0)
    low = np.full(m.shape, 0.3)
    low[0, 0] = 0.301  # flat for Eq. 7 but not constant (a constant region is rejected for that alone)
    v = given_verdict(m, low, guide, (20, 170), (180, 170))  # never above 0.3: a low threshold
    assert v.accepted and v.threshold == pytest.approx(0.29)  # is no reason (studies/plan_defaults)
    v = given_verdict(m, np.zeros(m.shape), guide, (20, 170), (180, 170))  # joins start and goal at no threshold
    assert not v.accepted and v.threshold is None
    assert v.reason == "no region threshold connects start and goal (Eq. 7 threshold none)"
    through_wall = np.zeros(m.shape)
    through_wall[96:104, 0:100] = 1.0  # grid rows 24, 25 (map rows 96..103); the wall is cells 24..25 there
    v = given_verdict(m, region, through_wall, (20, 170), (180, 170))
    assert not v.accepted and v.guideline_on_obstacles == pytest.approx(1.0)
    assert v.reason == "100% of the guideline lies on obstacles"


def test_fallback_runs_iql_bfs_and_says_so():
    m = corridor_map()
    flat = (np.zeros(m.shape), np.full(m.shape, 0.2))  # a region that joins start and goal at no threshold
    with pytest.warns(FallbackWarning, match="NDR-QL did not run, IQL-BFS ran instead"):
        report = ndrql.solve(m, (20, 20), (180, 20), "NDR-QL", 1, predictions=flat, workers=1)
    assert report.methods == ("IQL-BFS",) and report.results[0].method == "IQL-BFS"
    run = report.results[0]
    assert run.requested_method == "NDR-QL" and run.fell_back and "no region threshold" in run.fallback_reason
    assert report.to_dict()["runs"][0]["requested_method"] == "NDR-QL" and report.requested_methods == ("NDR-QL",)
    assert report.info["fallback"]["requested"] == ["NDR-QL"] and report.info["fallback"]["ran"] == "IQL-BFS"
    d = report.to_dict()
    assert d["prediction_quality"]["informative"] is False and d["prediction_quality"]["source"] == "file"
    assert d["policy"] == ["file"] and [t["source"] for t in d["sources"]] == ["file"]
    assert d["sources"][0]["accepted"] is False and d["sources"][0]["threshold"] is None
    kept = ndrql.solve(m, (20, 20), (180, 20), "NDR-QL", 1, predictions=flat, workers=1,
                       settings=PlanSettings(fallback=None))  # the given priors kept, and the mask is empty
    assert kept.methods == ("NDR-QL",) and "fallback" not in kept.info and kept.thresholds["NDR-QL"] is None
    assert kept.to_dict()["ndr_qi_threshold_reason"]["NDR-QL"].startswith("mask 0 everywhere: no threshold in")
    assert kept.results[0].requested_method == "NDR-QL" and kept.results[0].fallback_reason is None
    good = ndrql.solve(m, (20, 170), (180, 170), "NDR-QL", 1, predictions=good_prediction(m), workers=1)
    assert good.methods == ("NDR-QL",) and good.info["prediction_quality"]["informative"]
    assert good.info["sources"][0]["accepted"] and good.info["sources"][0]["threshold"] == pytest.approx(
        good.thresholds["NDR-QL"], abs=1e-4)  # the preset's own schedule, searched once
    assert good.thresholds["NDR-QL"] > 0.8
    with pytest.warns(FallbackWarning, match="NDR-QL did not run, IQL ran instead"):  # an explicit fallback
        iql = ndrql.solve(m, (20, 20), (180, 20), "NDR-QL", 1, predictions=flat, workers=1, fallback="IQL")
    assert iql.methods == ("IQL",)
    both = ndrql.solve(m, (20, 20), (180, 20), ["IQL", "NDR-QL"], 1, predictions=flat, workers=1, fallback="IQL")
    assert both.methods == ("IQL", "NDR-QL")  # a comparison that runs the fallback anyway keeps every method
    assert both.thresholds["NDR-QL"] is None and "fallback" not in both.info


def test_fallback_setting_is_checked():
    with pytest.raises(ndrql.api.NdrqlError, match="uses the model itself"):
        PlanSettings(fallback="NDR-QL")
    with pytest.raises(ndrql.api.NdrqlError, match="unknown method"):
        PlanSettings(fallback="DQN")
    assert PlanSettings(fallback="iql").fallback == "IQL" and PlanSettings.paper().fallback is None
    assert PlanSettings(fallback="iql-bfs").fallback == "IQL-BFS"


def test_cli_prints_one_line_and_the_json_says_which_ran(ndrql_exe, tmp_path):
    m = corridor_map()
    np.save(tmp_path / "m.npy", m)
    np.savez(tmp_path / "flat.npz", region=np.zeros(m.shape), guideline=np.full(m.shape, 0.2))  # joins nothing
    base = ["plan", str(tmp_path / "m.npy"), "--start", "20,20", "--goal", "180,20", "--prior-from",
            str(tmp_path / "flat.npz"), "--json", str(tmp_path / "p.json")]
    r = run_cli(ndrql_exe, *base)
    assert r.returncode == 0, r.stderr
    line = [x for x in r.stdout.splitlines() if x.startswith("prediction:")]
    assert len(line) == 1 and line[0].startswith("prediction: file rejected (no region threshold connects")
    assert "NDR-QL fell back to IQL-BFS (the exact BFS distance); --fallback none keeps the model's priors" in line[0]
    data = json.loads((tmp_path / "p.json").read_text())
    assert data["fallback"]["ran"] == "IQL-BFS" and data["runs"][0]["method"] == "IQL-BFS"
    assert data["sources"][0]["source"] == "file" and data["sources"][0]["accepted"] is False
    r = run_cli(ndrql_exe, *base, "--fallback", "none")
    assert r.returncode == 0 and "the rejected priors were used anyway (--fallback none)" in r.stdout
    assert json.loads((tmp_path / "p.json").read_text())["runs"][0]["method"] == "NDR-QL"
