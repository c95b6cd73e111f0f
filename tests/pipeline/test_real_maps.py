"""Plans that hold on the real map: the safe grid by default, every path checked on the full map, smoothing."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import ndrql
from ndrql.errors import NdrqlError, NoPathError, PointError
from ndrql.maps.grid import PlanningGrid
from ndrql.maps.lines import polyline_collisions
from ndrql.pipeline.problem import build_grid
from ndrql.pipeline.route import make_route, octile_cost
from ndrql.pipeline.settings import PlanSettings

from helpers.cli import run_cli
from ndrql.synth.drawn import OFFICE_GOAL, OFFICE_START, office_plan, thin_wall_map


@pytest.fixture(scope="module")
def office() -> np.ndarray:
    return office_plan()


def test_the_office_plan_gives_a_collision_free_path_by_default(office, model_weights):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = ndrql.solve(office, OFFICE_START, OFFICE_GOAL, "NDR-QL", 1, workers=1)
    run = report.results[0]
    assert report.setup.rule == "safe" and report.grid.cell_size[0] == report.grid.cell_size[1]
    assert run.converged and run.success and not run.collisions
    assert not polyline_collisions(office, run.route.pixels)  # checked independently, on the map as drawn
    assert tuple(run.route.pixels[0]) == OFFICE_START and tuple(run.route.pixels[-1]) == OFFICE_GOAL
    auto = report.setup.auto
    assert auto.within_tolerance and auto.chosen.ratio <= 1.08
    assert all(t.ratio is None or t.ratio > 1.08 for t in auto.trials[:-1])  # the smallest size that passes
    assert run.route.length <= run.route.grid_length
    assert run.route.length >= auto.full_length * 0.99  # an any-angle path may beat the octile optimum a little
    d = report.to_dict()
    assert d["runs"][0]["success"] is True and d["runs"][0]["collisions"] == []
    assert d["planning_grid"]["rule"] == "safe" and d["planning_grid"]["size"] == auto.size


def test_the_paper_grid_on_the_office_plan_is_reported_as_colliding(office):
    report = ndrql.solve(office, OFFICE_START, OFFICE_GOAL, "IQL", 1, workers=1, settings=PlanSettings.paper())
    run = report.results[0]
    assert report.grid.shape == (50, 50)
    assert run.converged and run.collisions and not run.success  # the 50x50 area grid erased the 8 px walls
    d = report.to_dict()["runs"][0]
    assert d["success"] is False and d["collisions"] and all(len(c["pixel"]) == 2 for c in d["collisions"])
    for seg, (r, c) in run.collisions:
        assert office[r, c]  # each reported pixel is a wall


def test_a_path_that_crosses_a_wall_is_a_collision_and_smoothing_keeps_it_honest():
    m = thin_wall_map(400)
    grid = PlanningGrid.from_map(m, (100, 100), (300, 100), size=50)  # the area rule drops the 1 px wall
    cells = [(12, 12), (13, 12), (37, 12)]
    raw = make_route(m, grid, [(r, 12) for r in range(12, 38)], ndrql.api.read_map(m), smooth=False)
    assert raw.collisions and raw.collides and raw.collisions[0][1][0] == 200
    smooth = make_route(m, grid, [(r, 12) for r in range(12, 38)], ndrql.api.read_map(m), smooth=True)
    assert smooth.collides  # no line of sight past the wall: the colliding segment stays and is reported
    assert cells  # (cells kept for readability of the case)


@pytest.mark.parametrize("seed", range(6))
def test_smoothing_never_introduces_a_collision(seed):
    rng = np.random.default_rng(seed)
    m = rng.random((300, 420)) < 0.0015
    m[100:104, :330] = True
    m[200:203, 90:] = True
    free = np.argwhere(~m)
    start, goal = (5, 5), (290, 410)
    m[start] = m[goal] = False
    gm = ndrql.api.read_map(m)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pg, setup = build_grid(gm, start, goal, PlanSettings(size=84))
    from ndrql.maps.astar import astar4

    cells = astar4(pg.blocked, pg.start, pg.goal).path
    route = make_route(setup.check_map, pg, cells, gm, smooth=True)
    assert not route.collisions and not route.final_collisions
    assert route.length <= route.grid_length + 1e-9
    assert len(free) > 0


def test_a_non_square_map_gets_square_cells():
    m = np.zeros((310, 800), dtype=bool)
    m[150, 100:] = True
    report = ndrql.solve(m, (20, 700), (305, 700), "QL", 1, workers=1, settings=PlanSettings(size=40))
    assert report.grid.shape == (15, 40)  # 310 / 20 px = 15.5 cells: the 16th's centre would be on the edge
    assert report.grid.goal == (14, 35)  # a point in the uncovered strip goes to the last row of cells
    assert report.grid.cell_size == (20.0, 20.0)
    assert report.results[0].success


def test_thin_wall_survives_end_to_end():
    m = thin_wall_map(400)
    report = ndrql.solve(m, (100, 100), (300, 100), "QL", 1, workers=1)
    run = report.results[0]
    assert run.success and not polyline_collisions(m, run.route.pixels)
    assert max(c for _, c in run.route.pixels) > 340 - 1  # it goes round through the opening on the right


def test_a_door_narrower_than_a_cell_closes_and_auto_refines():
    m = np.zeros((1000, 1000), dtype=bool)
    m[500:505, :] = True
    m[500:505, 600:612] = False  # a 12 px door
    with pytest.raises(NoPathError, match=r"--size \d+ connects them"):
        ndrql.solve(m, (100, 100), (900, 100), "QL", 1, workers=1, settings=PlanSettings(size=50))  # 20 px cells
    report = ndrql.solve(m, (100, 100), (900, 100), "QL", 1, workers=1)
    assert report.grid.cell_size[0] <= 12 and report.results[0].success


def test_no_grid_fits_names_the_bottleneck():
    m = np.zeros((1200, 1200), dtype=bool)
    m[600:604, :] = True
    m[600:604, 700:703] = False  # a 3 px gap
    with pytest.raises(NoPathError, match=r"passage at pixel \(60\d, 70\d\) is about 3 px wide and the finest grid has 9.4 px cells"):
        ndrql.solve(m, (100, 100), (1100, 100), "QL", 1, workers=1, settings=PlanSettings(max_size=128))


def test_a_diagonal_corridor_that_no_grid_keeps_is_planned_on_the_maps_own_pixels():
    # a 3 px band along the diagonal: its widest pixels touch only at corners, which no move may cut;
    # no grid up to 128 cells keeps it, the map's own pixels (240 cells, within the hard limit) do
    n = 240
    r, c = np.mgrid[:n, :n]
    m = np.abs(r - c) > 1
    m[:20, :20] = m[-20:, -20:] = False
    with pytest.warns(UserWarning, match="planning on the map's own pixels \\(240 cells"):
        report = ndrql.solve(m, (5, 5), (n - 5, n - 5), "QL", 1, workers=1, settings=PlanSettings(max_size=128))
    assert report.setup.auto.own_pixels and report.grid.shape == (n, n)
    assert report.results[0].success and not polyline_collisions(m, report.results[0].route.pixels)


def test_inflation_closes_a_gap_narrower_than_the_robot():
    m = np.zeros((400, 400), dtype=bool)
    m[200:204, :] = True
    m[200:204, 150:160] = False  # 10 px door
    m[300:304, :] = False
    report = ndrql.solve(m, (100, 50), (350, 50), "QL", 1, workers=1, settings=PlanSettings(robot_radius=4))
    assert report.results[0].success
    with pytest.raises(NoPathError, match="not connected on the map itself with obstacles inflated"):
        ndrql.solve(m, (100, 50), (350, 50), "QL", 1, workers=1, settings=PlanSettings(robot_radius=5))
    with pytest.raises(PointError, match="within the robot radius"):
        ndrql.solve(m, (196, 50), (350, 50), "QL", 1, workers=1, settings=PlanSettings(robot_radius=5))


def test_settings_are_checked():
    with pytest.raises(NdrqlError, match="size auto needs the safe grid"):
        PlanSettings(grid="area", size="auto")
    with pytest.raises(NdrqlError, match="unknown planning grid rule"):
        PlanSettings(grid="fine")
    with pytest.raises(NdrqlError, match="larger than the limit"):
        PlanSettings(size=600)
    with pytest.raises(NdrqlError, match="robot.radius"):
        PlanSettings(robot_radius=-1)
    assert PlanSettings(size="64").grid_size == 64 and PlanSettings().grid_size == "auto"
    assert PlanSettings.paper().grid_size == 50 and not PlanSettings.paper().smoothing and PlanSettings().smoothing


def test_same_seed_same_route_and_octile_cost():
    m = thin_wall_map(400)
    a = ndrql.plan(m, (100, 100), (300, 100), method="QL", seed=3, workers=1)
    b = ndrql.plan(m, (100, 100), (300, 100), method="QL", seed=3, workers=1)
    assert np.array_equal(a.route.pixels, b.route.pixels) and a.success == b.success
    assert octile_cost([(0, 0), (3, 4)]) == pytest.approx(4 + 3 * (2 ** 0.5 - 1))


def test_a_colliding_path_is_called_out_by_the_cli_and_marked_in_the_figure(ndrql_exe, office, tmp_path):
    import json
    
    from PIL import Image

    Image.fromarray(np.where(office, 0, 255).astype(np.uint8)).save(tmp_path / "office.png")
    r = run_cli(ndrql_exe, "plan", str(tmp_path / "office.png"), "--start", "300,200", "--goal", "1700,1800",
                "--method", "IQL", "--grid", "area", "--size", "50", "--json", str(tmp_path / "p.json"),
                "--png", str(tmp_path / "p.png"))
    assert r.returncode == 0, r.stderr  # the command worked; the answer is "this path does not hold"
    assert "IQL seed 0: path collides:" in r.stdout and "not a success" in r.stdout
    data = json.loads((tmp_path / "p.json").read_text())
    assert data["runs"][0]["success"] is False and data["runs"][0]["collisions"]
    assert data["summary"]["IQL"]["collide"] == 1 and (tmp_path / "p.png").stat().st_size > 0


def test_plan_figure_marks_collisions(office):
    from ndrql.viz.plan import plan_figure

    report = ndrql.solve(office, OFFICE_START, OFFICE_GOAL, "IQL", 1, workers=1, settings=PlanSettings.paper())
    fig = plan_figure(report)
    labels = [c.get_label() for ax in fig.axes for c in ax.collections]
    n = len(report.results[0].collisions)
    assert n and f"collision ({n})" in labels
    assert "PATH COLLIDES" in fig.axes[0].get_title()
