"""A*: known optimal lengths (hand-written MovingAI scenarios) and invariants on real dataset samples."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from ndrql.errors import NoPathError, PointError
from ndrql.maps import (
    PlanningGrid,
    astar4,
    astar8,
    bfs_distances,
    octile,
    path_is_valid,
    read_movingai_map,
    read_movingai_scen,
    shortest_path8,
)
from ndrql.maps.astar import _astar8_python

S2 = math.sqrt(2.0)

# Hand-written MovingAI benchmark: maps plus a .scen whose optimal lengths were worked out by hand
# (no corner cutting: a diagonal step needs both orthogonal neighbours free).
MAPS = {
    # Cutting the corner of '@' would give sqrt(2); the legal optimum goes around it: 2.
    "corner.map": ["..", "@."],
    # One block on the main diagonal: a 3-diagonal path must land on or cut past (2, 2), so the optimum
    # is 2 diagonals + 4 straight moves = 4 + 2*sqrt(2); corner cutting would give 2 + 3*sqrt(2).
    "diag.map": [".....", ".....", "..@..", ".....", "....."],
    # A wall with a gap at the right end; cutting the corners at the gap would give 6 + 2*sqrt(2).
    # Non-square on purpose (3 rows x 5 cols) so that a swapped x/y fails.
    "wall.map": [".....", "@@@@.", "....."],
    # Open room with a tree and water placed off both diagonal bands (and their corner cells), so
    # the plain octile distance is the optimum.
    "room.map": ["........", "........", ".......W", "T.......", "........", "........"],
}
SCEN = [
    # bucket, map, width, height, start_x, start_y, goal_x, goal_y, optimal length
    (0, "corner.map", 2, 2, 0, 0, 1, 1, 2.0),
    (0, "diag.map", 5, 5, 0, 0, 4, 4, 4 + 2 * S2),
    (0, "diag.map", 5, 5, 2, 0, 4, 2, 2 * S2),  # a diagonal clear of the block
    (0, "wall.map", 5, 3, 0, 0, 0, 2, 10.0),
    (0, "wall.map", 5, 3, 4, 0, 4, 2, 2.0),
    (1, "room.map", 8, 6, 0, 0, 7, 5, 5 * S2 + 2),
    (1, "room.map", 8, 6, 0, 5, 7, 0, 5 * S2 + 2),
    (1, "room.map", 8, 6, 3, 0, 3, 5, 5.0),
]
CUTTING = {("corner.map", 0): S2, ("diag.map", 1): 2 + 3 * S2, ("wall.map", 3): 6 + 2 * S2}


@pytest.fixture()
def benchmark(tmp_path):
    for name, rows in MAPS.items():
        text = f"type octile\nheight {len(rows)}\nwidth {len(rows[0])}\nmap\n" + "\n".join(rows) + "\n"
        (tmp_path / name).write_text(text)
    lines = ["version 1"] + ["\t".join(str(v) if not isinstance(v, float) else f"{v:.8f}" for v in row) for row in SCEN]
    (tmp_path / "bench.scen").write_text("\n".join(lines) + "\n")
    return tmp_path


def test_astar8_reproduces_scen_optimal_lengths(benchmark):
    scenarios = read_movingai_scen(benchmark / "bench.scen")
    assert len(scenarios) == len(SCEN)
    for k, s in enumerate(scenarios):
        m = read_movingai_map(benchmark / s.map)
        assert (m.width, m.height) == (s.width, s.height)
        res = astar8(m.obstacles, s.start, s.goal)
        assert res.cost == pytest.approx(s.optimal_length, abs=1e-6), (k, s)
        assert res.path[0] == s.start and res.path[-1] == s.goal
        assert path_is_valid(m.obstacles, res.path, diagonal=True)
        steps = sum(S2 if abs(a[0] - b[0]) + abs(a[1] - b[1]) == 2 else 1.0 for a, b in zip(res.path, res.path[1:]))
        assert steps == pytest.approx(res.cost)
        assert res.cost >= octile(s.start, s.goal) - 1e-9


def test_corner_cutting_would_be_shorter_and_wrong(benchmark):
    scenarios = read_movingai_scen(benchmark / "bench.scen")
    for k, s in enumerate(scenarios):
        m = read_movingai_map(benchmark / s.map)
        cut = astar8(m.obstacles, s.start, s.goal, corner_cutting=True)
        if (s.map, k) in CUTTING:
            assert cut.cost == pytest.approx(CUTTING[(s.map, k)])
            assert cut.cost < s.optimal_length - 0.1
            assert not path_is_valid(m.obstacles, cut.path, diagonal=True)
        else:
            assert cut.cost == pytest.approx(s.optimal_length)


def test_astar4_known_answers():
    blocked = np.zeros((5, 5), dtype=bool)
    assert astar4(blocked, (0, 0), (4, 4)).moves == 8
    assert astar4(blocked, (2, 2), (2, 2)).path == [(2, 2)]
    blocked[1:, 2] = True  # wall with a gap on top
    res = astar4(blocked, (4, 0), (4, 4))
    assert res.moves == 4 + 4 + 4 and res.cost == 12
    assert path_is_valid(blocked, res.path)
    assert res.expanded >= res.moves


@pytest.mark.parametrize("search", [astar4, astar8, shortest_path8, _astar8_python],
                         ids=["astar4", "astar8", "shortest_path8", "astar8-python"])
def test_search_errors(search):
    blocked = np.zeros((3, 3), dtype=bool)
    blocked[:, 1] = True  # a wall right across
    with pytest.raises(NoPathError):
        search(blocked, (0, 0), (0, 2))
    with pytest.raises(PointError, match="off"):
        search(blocked, (0, 0), (3, 0))
    with pytest.raises(PointError, match="obstacle"):
        search(blocked, (0, 1), (0, 0))


def test_astar4_is_deterministic_and_stateless():
    rng = np.random.default_rng(3)
    blocked = rng.random((30, 30)) < 0.2
    blocked[0, 0] = blocked[29, 29] = False
    dist = bfs_distances(blocked, (0, 0))
    assert dist[29, 29] > 0  # seed 3 gives a connected map
    a = astar4(blocked, (0, 0), (29, 29))
    b = astar4(blocked, (0, 0), (29, 29))
    assert a == b and a.moves == dist[29, 29]


@pytest.mark.parametrize("seed", range(6))
def test_astar_lengths_equal_bfs_on_random_grids(seed):
    rng = np.random.default_rng(seed)
    blocked = rng.random((25, 35)) < 0.3
    free = np.argwhere(~blocked)
    s, g = (tuple(int(v) for v in free[i]) for i in rng.choice(len(free), 2, replace=False))
    dist = bfs_distances(blocked, s)
    if dist[g] < 0:
        with pytest.raises(NoPathError):
            astar4(blocked, s, g)
        return
    res = astar4(blocked, s, g)
    assert res.moves == dist[g] and path_is_valid(blocked, res.path)


@pytest.mark.data
@pytest.mark.parametrize("split, index", [("seen", 0), ("seen", 450), ("unseen", 700), ("unseen", 1000), ("train", 7777)])
def test_astar4_on_real_samples_is_shortest_and_collision_free(dataset_root, split, index):
    from ndrql.dataset.layout import load_sample

    sample = load_sample(dataset_root, split, index)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pg = PlanningGrid.from_map(sample.map, sample.start, sample.goal)
    res = astar4(pg.blocked, pg.start, pg.goal)
    assert res.path[0] == pg.start and res.path[-1] == pg.goal
    assert path_is_valid(pg.blocked, res.path)  # collision-free, unit 4-connected steps
    assert res.moves == bfs_distances(pg.blocked, pg.start)[pg.goal]
    assert res.moves >= abs(pg.start[0] - pg.goal[0]) + abs(pg.start[1] - pg.goal[1])


def _dijkstra8(blocked: np.ndarray, start, goal) -> float:
    """Independent reference: scipy Dijkstra on the 8-connected graph without corner cutting."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    h, w = blocked.shape
    rows, cols, costs = [], [], []
    for r in range(h):
        for c in range(w):
            if blocked[r, c]:
                continue
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    nr, nc = r + dr, c + dc
                    if (dr, dc) == (0, 0) or not (0 <= nr < h and 0 <= nc < w) or blocked[nr, nc]:
                        continue
                    if dr and dc and (blocked[nr, c] or blocked[r, nc]):
                        continue
                    rows.append(r * w + c)
                    cols.append(nr * w + nc)
                    costs.append(S2 if dr and dc else 1.0)
    graph = coo_matrix((costs, (rows, cols)), shape=(h * w, h * w)).tocsr()
    return float(dijkstra(graph, indices=start[0] * w + start[1])[goal[0] * w + goal[1]])


@pytest.mark.parametrize("seed", range(5))
def test_astar8_matches_dijkstra_on_random_maps(seed):
    rng = np.random.default_rng(100 + seed)
    blocked = rng.random((20, 27)) < 0.3
    free = np.argwhere(~blocked)
    s, g = (tuple(int(v) for v in free[i]) for i in rng.choice(len(free), 2, replace=False))
    ref = _dijkstra8(blocked, s, g)
    if math.isinf(ref):
        with pytest.raises(NoPathError):
            astar8(blocked, s, g)
    else:
        res = astar8(blocked, s, g)
        assert res.cost == pytest.approx(ref) and path_is_valid(blocked, res.path, diagonal=True)


@pytest.mark.data
def test_known_disconnected_sample_raises_no_path_error(dataset_root):
    # SPEC section 1: the >= 0.5 rule closes narrow gaps; SEEN 904 is one of the 27 such SEEN samples.
    from ndrql.dataset.layout import load_sample

    sample = load_sample(dataset_root, "seen", 904)
    with pytest.raises(NoPathError, match="not 4-connected"):
        PlanningGrid.from_map(sample.map, sample.start, sample.goal)
    assert bfs_distances(sample.map, sample.start)[sample.goal] > 0  # but the full-resolution map connects them


@pytest.mark.parametrize("seed", range(40))
def test_shortest_path8_equals_python_astar8_on_random_maps(seed):
    # The compiled search pops the same nodes in the same order as the pure-Python reference: same
    # path, bit-identical cost, same expansions (which is why astar8 may delegate to it).
    rng = np.random.default_rng(500 + seed)
    h, w = (int(v) for v in rng.integers(4, 48, 2))
    blocked = rng.random((h, w)) < rng.uniform(0.0, 0.45)
    free = np.argwhere(~blocked)
    if len(free) < 2:
        return
    s, g = (tuple(int(v) for v in free[i]) for i in rng.choice(len(free), 2, replace=False))
    for cutting in (False, True):
        try:
            ref = _astar8_python(blocked, s, g, corner_cutting=cutting)
        except NoPathError:
            with pytest.raises(NoPathError):
                astar8(blocked, s, g, corner_cutting=cutting)
            if not cutting:
                with pytest.raises(NoPathError):
                    shortest_path8(blocked, s, g)
            continue
        got = astar8(blocked, s, g, corner_cutting=cutting)
        assert got == ref  # path, cost and expanded all equal
        if not cutting:
            assert shortest_path8(blocked, s, g) == ref
            assert path_is_valid(blocked, got.path, diagonal=True)


def test_shortest_path8_known_answers():
    blocked = np.zeros((3, 5), dtype=bool)
    blocked[1, :4] = True  # wall with a gap at the right end (the wall.map scenario above)
    res = shortest_path8(blocked, (0, 0), (2, 0))
    assert res.cost == pytest.approx(10.0) and res.path[0] == (0, 0) and res.path[-1] == (2, 0)
    assert path_is_valid(blocked, res.path, diagonal=True)
    assert shortest_path8(blocked, (0, 2), (0, 2)).path == [(0, 2)]


def test_shortest_path8_large_open_map():
    # 2000x2000 (4 million cells) runs in a fraction of a second; no timing asserted, only the answer.
    blocked = np.zeros((2000, 2000), dtype=bool)
    res = shortest_path8(blocked, (0, 0), (1999, 1000))
    assert res.cost == pytest.approx(octile((0, 0), (1999, 1000)))
    assert res.path[0] == (0, 0) and res.path[-1] == (1999, 1000) and res.moves == 1999
    blocked[1000, :1999] = True  # a wall with a one-cell gap at the right edge
    res = shortest_path8(blocked, (0, 0), (1999, 0))
    # No corner cutting: the gap cell (1000, 1999) is entered from above and left downwards, straight.
    assert (999, 1999) in res.path and (1000, 1999) in res.path and (1001, 1999) in res.path
    assert res.cost == pytest.approx(octile((0, 0), (999, 1999)) + 2 + octile((1001, 1999), (1999, 0)))
    assert path_is_valid(blocked, res.path, diagonal=True)
