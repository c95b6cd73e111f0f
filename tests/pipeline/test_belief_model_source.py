"""The network on a belief map (issue 54): ModelSource passes the planning grid's unknown cells to a model with the
unknown channel, and a model without it predicts as before."""

from __future__ import annotations

import numpy as np
import pytest
import torch

import ndrql
from ndrql.maps.belief import unknown_cells
from ndrql.maps.grid import GridMap
from ndrql.maps import sizing
from ndrql.model.checkpoint import save_checkpoint
from ndrql.model.predict import Predictor
from ndrql.model.registry import build_model
from ndrql.pipeline.sources import ModelSource, SourceDeclined, SourceInput

START, GOAL = (6, 6), (90, 90)


def _problem(unknown_px: np.ndarray | None):
    m = np.zeros((96, 96), bool)
    m[40:44, 10:80] = True
    grid = sizing.safe_grid(m, 24, START, GOAL)
    unknown = None if unknown_px is None else unknown_cells(unknown_px, grid)
    return SourceInput(grid, GridMap(m), START, GOAL, partial=unknown is not None, unknown=unknown)


def _predictor(encoding: str) -> Predictor:
    torch.manual_seed(3)
    cfg = {"arch": "ndr", "encoding": encoding, "width": 0.25, "unet_base": 8, "input_mode": "grid",
           "in_channels": 4 if encoding == "point+unknown" else 3}
    p = Predictor.from_model(build_model(cfg).eval(), encoding, threads=1)
    p.input_mode = "grid"
    return p


def _hidden() -> np.ndarray:
    unknown = np.zeros((96, 96), bool)
    unknown[30:60, 0:50] = True
    return unknown


def test_model_with_the_channel_sees_the_unknown_cells():
    source = ModelSource(_predictor("point+unknown"))
    seen = source.give(_problem(_hidden()))
    plain = source.give(_problem(None))
    assert seen.info["unknown_cells"] > 0 and "unknown_cells" not in plain.info
    assert np.abs(seen.region - plain.region).max() > 1e-6


def test_model_without_the_channel_ignores_the_cells_and_declines_a_belief_map():
    """Unknown cells given to a model without the channel change nothing; on a belief map it declines (the plan
    then runs its fallback)."""
    source = ModelSource(_predictor("point"))
    hidden = _problem(_hidden())
    seen = source.give(SourceInput(hidden.grid, hidden.grid_map, START, GOAL, unknown=hidden.unknown))
    plain = source.give(_problem(None))
    np.testing.assert_array_equal(seen.region, plain.region)
    np.testing.assert_array_equal(seen.guideline, plain.guideline)
    assert "unknown_cells" not in seen.info
    with pytest.raises(SourceDeclined):
        source.give(hidden)


def test_plan_with_hide_feeds_a_belief_model(tmp_path):
    """End to end: ``solve(hide=...)`` with a belief model's weights runs and says how many cells it saw unknown."""
    torch.manual_seed(4)
    cfg = {"arch": "ndr", "encoding": "point+unknown", "in_channels": 4, "width": 0.25, "unet_base": 8,
           "input_mode": "grid"}
    weights = save_checkpoint(tmp_path / "belief.pt", {"config": cfg, "model": build_model(cfg).state_dict()})
    m = np.zeros((96, 96), bool)
    m[40:44, 10:80] = True
    report = ndrql.solve(m, START, GOAL, methods=["NDR-QL"], seeds=[0], hide=_hidden(), weights=str(weights),
                         backend="torch", size=24, predict_budget=None)
    info = report.to_dict()
    assert info["sources"][0]["source"] == "model" and info["sources"][0]["accepted"]
    assert info["model_input"]["unknown_cells"] > 0


def test_a_predicted_distance_on_a_belief_map_never_goes_below_the_beliefs_bfs():
    """The belief's BFS distance (unknown counted free) is the shortest the truth can hold: the floor keeps the
    predicted detours and lifts the predicted shortcuts to it."""
    from ndrql.pipeline.sources import belief_floor, exact_distance_field

    grid = _problem(_hidden()).grid
    bfs = exact_distance_field(grid.blocked, grid.goal)
    shortcut = np.zeros(grid.blocked.shape)
    np.testing.assert_array_equal(belief_floor(shortcut, grid.blocked, grid.goal), bfs)
    detour = bfs + 7.0
    np.testing.assert_array_equal(belief_floor(detour, grid.blocked, grid.goal), detour)
    mixed = np.where(np.arange(bfs.size).reshape(bfs.shape) % 2 == 0, bfs - 3.0, bfs + 5.0)
    np.testing.assert_array_equal(belief_floor(mixed, grid.blocked, grid.goal), np.maximum(mixed, bfs))
