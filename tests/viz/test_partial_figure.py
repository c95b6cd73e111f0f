"""The one-map figure of ``ndrql reproduce partial``: which map it shows (picked from the records alone) and what
each panel draws (the planner's view on panels 2 and 3, the truth only on panels 1 and 4)."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.api import run_request
from ndrql.experiments.partial import REF, Task, _generated, one_case, parse_beliefs, plan_request
from ndrql.experiments.partial_run import figure_record, map_figure
from ndrql.viz.partial import UNSEEN_COLOR, belief_figure, prediction_title

SET = "partial-dev"


def _rows(steps: dict[str, list[int]]) -> dict:
    return {k: {"steps": v, "converged": [True] * len(v), "ratio": [1.0] * len(v), "seconds": 0.0}
            for k, v in steps.items()}


def _records(spec: list[tuple[int, int, str, bool, float, str | None, bool]]) -> list[dict]:
    """One truth record and one belief record per ``(index, grid, belief, sense, oracle / IQL-BFS, served,
    fell back)``: IQL-BFS (belief) takes 1000 steps, the oracle ``1000 * gain``."""
    out = []
    for index, grid, belief, sense, gain, served, fell in spec:
        out.append({"index": index, "family": "rooms", "grid": grid, "belief": None, "sense": False,
                    "rows": _rows({"IQL": [900, 900], "NDR-QL (oracle)": [round(1000 * gain)] * 2})})
        out.append({"index": index, "family": "rooms", "grid": grid, "belief": belief, "sense": sense,
                    "rows": _rows({REF: [1000, 1000], "NDR-QL": [800, 800]}),
                    "ndr": {"served": served, "fallback": {"ran": "IQL-BFS", "reasons": ["x"]} if fell else None}})
    return out


def test_the_picked_map_is_the_one_where_the_oracle_gains_most_among_served_maps():
    recs = _records([
        (0, 50, "blobs:0.3", False, 0.90, "exact", False),
        (1, 50, "blobs:0.3", False, 0.40, "model", False),   # the largest gain of the reported setting: picked
        (2, 50, "blobs:0.3", False, 0.10, None, True),       # larger, but NDR-QL fell back
        (3, 100, "blobs:0.3", False, 0.05, "exact", False),  # larger, but not the first grid
        (4, 50, "blobs:0.3", True, 0.05, "exact", False),    # larger, but with sensing
        (5, 50, "blobs:0.1", False, 0.05, "exact", False),   # larger, but another setting
        (6, 50, "blobs:0.3", False, 0.60, "exact", False),
    ])
    rec = figure_record(recs, (50, 100))
    assert rec["index"] == 1 and rec["rows"]["NDR-QL (oracle)"]["steps"] == [400, 400]  # the truth's rows joined in
    tie = _records([(7, 50, "blobs:0.3", False, 0.4, "exact", False), (3, 50, "blobs:0.3", False, 0.4, "exact", False)])
    assert figure_record(tie, (50,))["index"] == 3  # ties: the lowest index
    none_served = _records([(0, 50, "blobs:0.3", False, 0.7, None, True), (1, 50, "blobs:0.3", False, 0.5, None, True)])
    assert figure_record(none_served, (50,))["index"] == 1  # nothing served: still the largest gain
    assert figure_record(_records([(0, 50, "blobs:0.3", False, 0.5, "exact", False)]), (100,)) is None


def test_panel_titles_name_the_source_that_served():
    assert prediction_title("model").startswith("the model's region")
    assert prediction_title("exact").startswith("the exact prior of the belief")
    assert "fell back" in prediction_title(None)


@pytest.fixture(scope="module")
def hidden_case():
    """A map of the development set whose blobs hide true obstacles, and NDR-QL's plan of it (no model)."""
    gs = _generated(SET, False)
    setting = parse_beliefs("blobs:0.3")[0]
    for index in range(len(gs)):
        pc = one_case(gs, index, 50, setting)
        if pc.case is not None and (pc.obstacles & pc.belief.unknown).sum() > 20:
            task = Task(SET, False, index, 50, (0,), "general", None, "blobs:0.3", False, run_request)
            return pc, run_request(plan_request(pc, task, "NDR-QL"))
    pytest.skip("no map of the set hides an obstacle")


def test_belief_panels_draw_the_planners_view_and_panel_4_the_walls_it_did_not_know(hidden_case):
    pc, report = hidden_case
    fig = belief_figure(report, pc.belief, report.region, report.guideline, source="exact")
    axes = fig.axes
    truth, view = np.asarray(pc.obstacles, bool), pc.belief.planner_obstacles("free")
    assert np.array_equal(np.asarray(axes[0].images[0].get_array(), bool), truth)
    for ax in axes[1:3]:  # the first image of panels 2 and 3: the obstacles drawn, the planner's, not the truth's
        drawn = np.asarray(ax.images[0].get_array(), bool)
        assert np.array_equal(drawn, view) and not np.array_equal(drawn, truth)
    assert axes[2].get_title().startswith("the exact prior of the belief")
    unseen = [im for im in axes[3].images if np.array_equal(np.asarray(im.get_array(), bool), truth & ~view)]
    assert len(unseen) == 1
    labels = [t.get_text() for t in axes[3].get_legend().get_texts()]
    assert any("did not know" in t for t in labels) and any(t.startswith("A*") for t in labels)
    assert UNSEEN_COLOR == "darkred"


def test_map_figure_writes_the_picked_map(tmp_path, hidden_case):
    pc, _ = hidden_case
    recs = _records([(pc.index, 50, "blobs:0.3", False, 0.3, "exact", False)])
    path = map_figure(tmp_path / "partial_map.png", _generated(SET, False), recs, (50,),
                      Task(SET, False, 0, 0, (0,), "general", None, runner=run_request))
    assert path is not None and path.is_file() and path.stat().st_size > 20_000
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
