"""One function builds the safe planning grid (blocked cells + start and goal cells): ``maps.sizing.safe_grid``.

A hand-computed small case pins what it builds; every command, env, data renderer and experiment that
turns a map + size into a safe planning grid goes through it (checked by counting calls and in the source).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import ndrql
import ndrql.maps.sizing as sizing
from ndrql.maps.sizing import safe_grid

SRC = Path(ndrql.__file__).parent


def test_hand_computed_case():
    # 4x6 map, 3 cells on the longer side: 2 px square cells, 2x3 cells; obstacle pixel (0, 2) blocks cell (0, 1).
    obstacles = np.zeros((4, 6), bool)
    obstacles[0, 2] = True
    pg = safe_grid(obstacles, 3, (0, 3), (3, 0))
    assert pg.blocked.tolist() == [[False, True, False], [False, False, False]]
    # start pixel (0, 3) lies in blocked cell (0, 1); the free cell whose centre (0.5, 4.5) is nearest
    # (1.58 px) and visible from it is (0, 2). Goal pixel (3, 0) lies in free cell (1, 0).
    assert (pg.start, pg.goal, pg.snapped) == ((0, 2), (1, 0), (True, False))
    assert pg.cell_px == (2.0, 2.0) and pg.source_shape == (4, 6)
    assert (pg.source_start, pg.source_goal) == ((0, 3), (3, 0))


def _map() -> np.ndarray:
    obstacles = np.zeros((40, 40), bool)
    obstacles[20, 5:40] = True  # a one-pixel wall; the way round is on the left
    return obstacles


@pytest.fixture
def calls(monkeypatch):
    seen = []
    real = sizing.safe_grid

    def counting(*args, **kwargs):
        seen.append(args[1])
        return real(*args, **kwargs)

    monkeypatch.setattr(sizing, "safe_grid", counting)
    return seen


def test_callers_go_through_the_builder(calls):
    from ndrql.dataset.render import render_grid
    from ndrql.env.sources import map_problem
    from ndrql.experiments.ceiling import grid_case
    from ndrql.maps.grid import GridMap
    from ndrql.pipeline.problem import build_grid
    from ndrql.pipeline.request import request_settings

    obstacles, start, goal = _map(), (2, 30), (37, 30)
    pg, _ = build_grid(GridMap(obstacles), start, goal, request_settings(grid="safe", size=20))
    assert calls == [20]
    case = map_problem("drawn", start, goal, 20, "safe", obstacles=obstacles)
    assert calls[-1] == 20 and (case.start, case.goal) == (pg.start, pg.goal)
    assert np.array_equal(case.blocked, pg.blocked)
    calls.clear()
    sizing.try_size(obstacles, start, goal, 10, 1.0)
    assert calls == [10]
    case = grid_case("c", "g", obstacles, start, goal, 20)
    assert calls[-1] == 20 and (case.start_cell, case.goal_cell) == (pg.start, pg.goal)
    assert np.array_equal(case.blocked, pg.blocked)
    calls.clear()
    assert render_grid(obstacles, start, goal, 20) is not None
    assert calls == [20]


def test_no_other_module_places_points_on_a_safe_grid():
    """``place_point`` is called only by the builder; ``conservative_grid`` (blocked cells alone) only by
    the builder and by ``map info``'s grid without a route."""
    allowed = {"conservative_grid(": {"maps/safe.py", "maps/sizing.py", "pipeline/problem.py"},
               "place_point(": {"maps/sizing.py"}}
    for call, homes in allowed.items():
        users = {p.relative_to(SRC).as_posix() for p in SRC.rglob("*.py")
                 if re.search(r"(?<![\w.])" + re.escape(call), p.read_text().replace(f"def {call}", ""))}
        assert users <= homes, (call, users - homes)
    problem = (SRC / "pipeline" / "problem.py").read_text()
    assert problem.count("conservative_grid(") == 1  # map_grid: the whole map's cells, no start or goal
    predict = (SRC / "model" / "predict.py").read_text()
    assert "safe_grid(obstacles" in predict
