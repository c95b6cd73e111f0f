"""Honest heuristics: an uninformative prediction is named, and --fallback plans with distance priors instead."""

from __future__ import annotations

import json

import numpy as np
import pytest

import ndrql
from ndrql.errors import FallbackWarning
from ndrql.planning.priors import ThresholdWarning
from ndrql.maps.grid import PlanningGrid
from ndrql.pipeline.predictions import prediction_quality
from ndrql.pipeline.settings import PlanSettings
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


def test_quality_of_hand_made_predictions():
    m = corridor_map()
    grid = PlanningGrid.from_map(m, (20, 170), (180, 170), size=50)
    region, guide = good_prediction(m)
    from ndrql.maps.grid import area_downscale

    q = prediction_quality(area_downscale(region), guide, m, grid, PriorConfig())
    assert q["informative"] and q["threshold"] == pytest.approx(0.89) and q["guideline_on_obstacles"] == 0.0
    q = prediction_quality(np.full((50, 50), 0.3), guide, m, grid, PriorConfig())  # never above 0.3: a low threshold
    assert q["informative"] and q["threshold"] == pytest.approx(0.29)  # is no reason (studies/plan_defaults)
    q = prediction_quality(np.zeros((50, 50)), guide, m, grid, PriorConfig())  # joins start and goal at no threshold
    assert not q["informative"] and q["threshold"] is None
    assert q["reasons"][0] == "no region threshold connects start and goal (Eq. 7 threshold none)"
    through_wall = np.zeros(m.shape)
    through_wall[97:103, 0:100] = 1.0  # rows 98..101 are wall: 4 of 6 rows on obstacles
    q = prediction_quality(area_downscale(region), through_wall, m, grid, PriorConfig())
    assert not q["informative"] and q["guideline_on_obstacles"] == pytest.approx(4 / 6)
    assert q["reasons"] == ["67% of the guideline lies on obstacles"]


def test_above_128_cells_a_region_that_joins_only_at_a_low_threshold_is_uninformative():
    """Grids above LARGE_GRID cells judge by LARGE_MIN_THRESHOLD (docs/large-maps.md): the same flat region is
    informative on a 100-cell grid and not on a 256-cell one."""
    from ndrql.pipeline.fallback import LARGE_GRID, LARGE_MIN_THRESHOLD, min_threshold

    assert min_threshold(LARGE_GRID) == 0.0 and min_threshold(LARGE_GRID + 1) == LARGE_MIN_THRESHOLD > 0
    m = np.zeros((512, 512), dtype=bool)
    m[250:262, :400] = True  # a wall with a gap on the right
    guide = np.zeros(m.shape)
    guide[20:500, 450] = 1.0
    flat = LARGE_MIN_THRESHOLD / 2 + 0.01  # the region joins start and goal just below the large grids' cut
    for size, informative in ((100, True), (256, False)):
        grid = PlanningGrid.from_map(m, (20, 450), (500, 450), size=size)
        q = prediction_quality(np.full(grid.blocked.shape, flat), guide, m, grid, PriorConfig())
        assert q["informative"] is informative and q["threshold"] < LARGE_MIN_THRESHOLD
        assert q["min_threshold"] == min_threshold(size)
    assert q["reasons"][0] == (f"no region threshold >= {LARGE_MIN_THRESHOLD} connects start and goal "
                               f"(Eq. 7 threshold {q['threshold']:.2f})")


def test_above_128_cells_a_region_over_most_of_the_free_cells_is_uninformative():
    """A region that joins start and goal at a high threshold but covers most of the free cells does not say
    where the path runs: uninformative above LARGE_GRID cells, informative (as before) up to it."""
    from ndrql.pipeline.fallback import LARGE_GRID, MAX_REGION_COVER, max_region_cover, region_cover

    assert max_region_cover(LARGE_GRID) is None and max_region_cover(LARGE_GRID + 1) == MAX_REGION_COVER
    m = np.zeros((512, 512), dtype=bool)
    m[250:262, :400] = True
    guide = np.zeros(m.shape)
    guide[20:500, 450] = 1.0
    for size, informative in ((100, True), (256, False)):
        grid = PlanningGrid.from_map(m, (20, 450), (500, 450), size=size)
        everywhere = np.full(grid.blocked.shape, 0.9)
        q = prediction_quality(everywhere, guide, m, grid, PriorConfig())
        assert q["informative"] is informative and q["threshold"] == pytest.approx(0.89)
        assert q["region_cover"] == pytest.approx(1.0)
        band = np.zeros(grid.blocked.shape)
        band[:, int(0.8 * size):] = 0.9  # the right fifth of the map, through the gap: informative at any size
        q2 = prediction_quality(band, guide, m, grid, PriorConfig())
        assert q2["informative"] and q2["region_cover"] == pytest.approx(
            region_cover(band, grid.blocked, q2["threshold"])) and q2["region_cover"] < MAX_REGION_COVER
    assert q["reasons"] == [f"the region covers 100% of the free cells at its Eq. 7 threshold 0.89 (at most "
                            f"{MAX_REGION_COVER:.0%} above {LARGE_GRID} cells)"]
    free = ~grid.blocked
    half = np.where(np.arange(grid.blocked.size).reshape(grid.blocked.shape) % 2 == 0, 0.9, 0.0)
    assert region_cover(half, grid.blocked, 0.5) == pytest.approx(np.count_nonzero((half > 0.5) & free) / free.sum())
    assert region_cover(half, grid.blocked, None) is None


def test_fallback_runs_iql_and_says_so():
    m = corridor_map()
    flat = (np.zeros(m.shape), np.full(m.shape, 0.2))  # a region that joins start and goal at no threshold
    with pytest.warns(FallbackWarning, match="NDR-QL did not run, IQL ran instead"):
        report = ndrql.solve(m, (20, 20), (180, 20), "NDR-QL", 1, predictions=flat, workers=1)
    assert report.methods == ("IQL",) and report.results[0].method == "IQL"
    run = report.results[0]
    assert run.requested_method == "NDR-QL" and run.fell_back and "no region threshold" in run.fallback_reason
    assert report.to_dict()["runs"][0]["requested_method"] == "NDR-QL" and report.requested_methods == ("NDR-QL",)
    assert report.info["fallback"]["requested"] == ["NDR-QL"] and report.info["fallback"]["ran"] == "IQL"
    assert report.to_dict()["prediction_quality"]["informative"] is False
    with pytest.warns(ThresholdWarning, match="no threshold"):  # the model's priors kept, and the mask is empty
        kept = ndrql.solve(m, (20, 20), (180, 20), "NDR-QL", 1, predictions=flat, workers=1,
                           settings=PlanSettings(fallback=None))
    assert kept.methods == ("NDR-QL",) and "fallback" not in kept.info
    good = ndrql.solve(m, (20, 170), (180, 170), "NDR-QL", 1, predictions=good_prediction(m), workers=1)
    assert good.methods == ("NDR-QL",) and good.info["prediction_quality"]["informative"]
    assert kept.results[0].requested_method == "NDR-QL" and kept.results[0].fallback_reason is None
    with pytest.warns(ThresholdWarning, match="no threshold"):
        both = ndrql.solve(m, (20, 20), (180, 20), ["IQL", "NDR-QL"], 1, predictions=flat, workers=1, fallback="IQL")
    assert both.methods == ("IQL", "NDR-QL")  # a comparison that runs the fallback anyway keeps every method


def test_fallback_setting_is_checked():
    with pytest.raises(ndrql.api.NdrqlError, match="uses the model itself"):
        PlanSettings(fallback="NDR-QL")
    with pytest.raises(ndrql.api.NdrqlError, match="unknown method"):
        PlanSettings(fallback="DQN")
    assert PlanSettings(fallback="iql").fallback == "IQL" and PlanSettings.paper().fallback is None


def test_cli_prints_one_line_and_the_json_says_which_ran(ndrql_exe, tmp_path):
    m = corridor_map()
    np.save(tmp_path / "m.npy", m)
    np.savez(tmp_path / "flat.npz", region=np.zeros(m.shape), guideline=np.full(m.shape, 0.2))  # joins nothing
    base = ["plan", str(tmp_path / "m.npy"), "--start", "20,20", "--goal", "180,20", "--prior-from",
            str(tmp_path / "flat.npz"), "--json", str(tmp_path / "p.json")]
    r = run_cli(ndrql_exe, *base)
    assert r.returncode == 0, r.stderr
    line = [x for x in r.stdout.splitlines() if x.startswith("prediction:")]
    assert len(line) == 1 and "uninformative" in line[0] and "NDR-QL fell back to IQL" in line[0]
    data = json.loads((tmp_path / "p.json").read_text())
    assert data["fallback"]["ran"] == "IQL" and data["runs"][0]["method"] == "IQL"
    r = run_cli(ndrql_exe, *base, "--fallback", "none")
    assert r.returncode == 0 and "the model's priors were used anyway" in r.stdout
    assert json.loads((tmp_path / "p.json").read_text())["runs"][0]["method"] == "NDR-QL"
