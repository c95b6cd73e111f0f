"""Prior sources behind one protocol (pipeline/sources.py): what each gives on the planning grid, the exact
source's region and distance, the digests, and which sources a request consults."""

from __future__ import annotations

import numpy as np
import pytest

import ndrql
from ndrql.errors import NdrqlError
from ndrql.maps.astar import astar4
from ndrql.maps.grid import GridMap, PlanningGrid, bfs_distances
from ndrql.pipeline.judge import judge
from ndrql.pipeline.request import request_sources
from ndrql.pipeline.settings import PlanSettings
from ndrql.pipeline.sources import (SOURCE_NAMES, ExactSource, GivenSource, GridPriors, HeadSource, ModelSource,
                                    OracleSource, SourceInput, default_policy, exact_distance_field)
from ndrql.planning.config import PriorConfig
from ndrql.synth.labels import near_optimal_path

from helpers import two_walls

START, GOAL = (10, 10), (110, 150)


def problem(size: int = 50, truth: np.ndarray | None = None) -> SourceInput:
    m = two_walls()
    grid = PlanningGrid.from_map(m, START, GOAL, size=size)
    return SourceInput(grid, GridMap(m), START, GOAL, truth)


def given_arrays() -> tuple[np.ndarray, np.ndarray]:
    m = two_walls()
    region = np.linspace(0.0, 1.0, m.size).reshape(m.shape)
    guide = np.zeros(m.shape)
    guide[10:110, 10] = 1.0
    return region, guide


def make(name: str):
    if name == "model":
        from ndrql.model.predict import load_predictor
        from ndrql.model.weights import shipped_weights

        return ModelSource(load_predictor(shipped_weights("general")))
    if name == "head":
        from ndrql.model import propagation

        if not propagation.available():
            pytest.skip("the propagating head is not installed (ndrql/data/propagator.onnx)")
        return HeadSource()
    if name == "file":
        return GivenSource(given_arrays())
    return {"exact": ExactSource, "oracle": OracleSource}[name]()


@pytest.mark.parametrize("name", SOURCE_NAMES)
@pytest.mark.parametrize("size", [50, 80])
def test_every_source_gives_priors_of_the_grids_shape_in_0_1(name, size):
    p = problem(size)
    src = make(name)
    out = src.give(p)
    shape = p.grid.blocked.shape
    assert isinstance(out, GridPriors) and out.source == src.name == name
    assert out.region.shape == shape and out.region.dtype == np.float64
    assert np.isfinite(out.region).all() and out.region.min() >= 0.0 and out.region.max() <= 1.0
    assert out.region.max() > 0.0  # says something
    if out.guideline is not None:
        assert out.guideline.shape == shape and out.guideline.min() >= 0.0 and out.guideline.max() <= 1.0
    if out.distance is not None:
        assert out.distance.shape == shape and np.isfinite(out.distance).all()  # cells; a model's may dip below 0
    if out.region_map is not None:  # at the map's resolution, for figures and the report
        assert out.region_map.shape == p.grid_map.shape
    assert isinstance(src.digest(), str) and isinstance(src.bounded, bool)


def test_the_exact_region_covers_the_a_star_route_and_its_distance_is_bfs():
    for size in (50, 80, 128):
        p = problem(size)
        g = p.grid
        out = ExactSource().give(p)
        bfs = bfs_distances(g.blocked, g.goal)
        reach = bfs >= 0
        assert np.array_equal(out.distance[reach], bfs[reach].astype(np.float64))
        assert (out.distance[~reach] > bfs.max()).all()  # unreachable cells: beyond every reachable one
        # the polyline the dataset's labels are drawn along (A*'s 8-connected path, shortcut) lies in the region
        # and on the guideline, and the region holds a 4-connected route as short as A*'s
        way = near_optimal_path(g.blocked, g.start, g.goal)
        assert min(out.region[tuple(c)] for c in way) == 1.0 and min(out.guideline[tuple(c)] for c in way) > 0
        moves = astar4(g.blocked, g.start, g.goal).moves
        inside = bfs_distances(g.blocked | ~(out.region > 0.99), g.goal)[tuple(g.start)]
        assert inside == moves
        v = judge(out.region, out.guideline, g.blocked, g.start, g.goal, PriorConfig())
        assert v.accepted and v.threshold == pytest.approx(0.99) and v.route_ratio == 1.0
        assert v.cover < 0.5  # a corridor, not the whole map
    assert out.weights == "exact BFS priors" and out.info["exact"] is True


def test_exact_distance_field_orders_the_cells_that_cannot_reach_the_goal():
    b = np.zeros((5, 7), dtype=bool)
    b[:, 3] = True  # the right half cannot reach a goal on the left
    d = exact_distance_field(b, (0, 0))
    assert d[0, 0] == 0 and d[4, 2] == 6
    assert d[0, 4] > d[4, 2] and d[0, 6] > d[0, 4]  # the largest finite value plus the Manhattan distance
    assert d[0, 4] == 6 + 4 and d[4, 6] == 6 + 10


def test_the_oracle_is_exact_on_a_known_map_and_drawn_from_the_truth_where_part_is_hidden():
    known = problem(50)
    exact, oracle = ExactSource().give(known), OracleSource().give(known)
    assert np.array_equal(oracle.distance, exact.distance)
    assert np.abs(oracle.region - exact.region).max() <= 0.25  # OpenCV's line rule: a pixel here and there
    # the planner believes a wall is closed (its belief blocks the gap at the right); the truth has the gap
    g = known.grid
    belief = g.blocked.copy()
    row = int(np.flatnonzero(belief[:, 0])[0])  # the first wall's top row (it starts at the left edge)
    belief[row, ~belief[row]] = True
    hidden = SourceInput(PlanningGrid(belief, g.start, g.goal, g.source_shape, g.source_start, g.source_goal),
                         known.grid_map, START, GOAL, truth=g.blocked)
    from_truth = OracleSource().give(hidden)
    assert np.array_equal(from_truth.distance, exact_distance_field(g.blocked, g.goal))
    assert np.array_equal(from_truth.region, exact.region)  # the truth's path, not the belief's
    assert from_truth.region_map is not None and from_truth.region_map.shape == known.grid_map.shape


def test_given_arrays_of_the_wrong_shape_are_refused():
    p = problem(50)
    with pytest.raises(NdrqlError, match="region prediction is 10x10 but the map is 120x160"):
        GivenSource((np.zeros((10, 10)), None)).give(p)


def test_digests_say_what_the_predictions_depend_on():
    region, guide = given_arrays()
    a, b = GivenSource((region, guide)).digest(), GivenSource((region * 0.5, guide)).digest()
    assert len(a) == 16 and a != b and a == GivenSource((region.copy(), guide.copy())).digest()
    assert ExactSource().digest() == "" and OracleSource().digest() == ""
    model = make("model")
    assert len(model.digest()) == 16 and model.digest() == str(model.predictor.weights_digest)[:16]


def test_the_default_policy_and_the_sources_a_request_names(monkeypatch):
    from pathlib import Path

    from ndrql.model import weights as w

    shipped = w.shipped_weights
    monkeypatch.setattr(w, "shipped_weights", lambda name: Path("/nonexistent/ndr_belief.pt") if name == "belief"
                        else shipped(name))  # no belief weights installed
    monkeypatch.delenv("NDRQL_WEIGHTS", raising=False)
    assert default_policy() == default_policy("map") == ("exact",)
    assert default_policy("sample") == ("model",) and default_policy("map", partial=True) == ("exact",)
    assert default_policy("map", partial=True, belief_model=True) == ("model", "exact")
    assert request_sources(None, None, "map", False) == ("exact",)
    assert request_sources(None, None, "sample", False) == ("model",)
    assert request_sources(None, None, "map", True) == ("exact",)
    monkeypatch.setattr(w, "shipped_weights", shipped)
    assert request_sources(None, None, "map", True) == (("model", "exact") if w.installed("belief") else ("exact",))
    assert request_sources(None, "paper", "map", False) == ("model",)  # weights name the model
    assert request_sources("oracle", None, "map", False) == ("oracle",)
    assert request_sources(given_arrays(), None, "map", False) == ("file",)
    assert request_sources(None, None, "map", False, PlanSettings(symmetries=4)) == ("model",)  # a model setting
    assert request_sources(None, None, "map", False, PlanSettings(size=64)) == ("exact",)
    m = two_walls()
    assert ndrql.build_request(m, START, GOAL).sources == ("exact",)
    assert ndrql.build_request(m, START, GOAL, predictions="model").sources == ("model",)
    assert ndrql.build_request(m, START, GOAL, predictions="head").sources == ("head",)
    with pytest.raises(NdrqlError, match="predictions must be"):
        ndrql.build_request(m, START, GOAL, predictions="file")
    with pytest.raises(NdrqlError, match="not both"):
        ndrql.build_request(m, START, GOAL, predictions="exact", weights="paper")
