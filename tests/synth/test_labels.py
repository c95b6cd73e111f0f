"""The dataset's label definition (ndrql.synth.labels), the oracle and the endpoint sampler.

Hand-computed labels on hand-made maps, pixel equality with OpenCV's drawing (a test dependency
only), pixel equality with the dataset's own labels, and the endpoint rules.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ndrql.errors import NdrqlError, NoPathError, PointError
from ndrql.maps.astar import shortest_path8
from ndrql.maps.lines import polyline_collisions, polyline_length
from ndrql.synth.endpoints import sample_endpoints
from ndrql.synth.labels import GUIDE_PX, REGION_PX, Labels, dilate_region, draw_guideline, make_labels, near_optimal_path
from ndrql.synth.oracle import cell_centres, oracle_prediction


def _cv2_polyline(shape, points, thickness, shift=0):
    """Reference drawing with OpenCV: ``cv2.line`` per consecutive pair (points ``(row, col)``)."""
    cv2 = pytest.importorskip("cv2")
    img = np.zeros(shape, np.uint8)
    pts = np.asarray(points)
    if shift:
        pts = np.rint(pts * (1 << shift)).astype(np.int64)
    for a, b in zip(pts, pts[1:]):
        cv2.line(img, (int(a[1]), int(a[0])), (int(b[1]), int(b[0])), 255, thickness, cv2.LINE_8, shift)
    return img > 0


def test_constants():
    assert (GUIDE_PX, REGION_PX) == (2, 30)


def test_guideline_known_answer():
    # cv2's thickness-2 line is 3 px across an axis-aligned segment (the quadrilateral p0 +- 1 px,
    # both edges drawn), with a plus-shaped end cap (filled circle of radius 1) at each end point.
    got = draw_guideline((9, 14), [(4, 1), (4, 11)])
    want = np.zeros((9, 14), bool)
    want[3:6, 1:12] = True
    want[4, 0] = want[4, 12] = True
    np.testing.assert_array_equal(got, want)
    # A single waypoint is its end cap; no waypoints, nothing.
    dot = draw_guideline((5, 5), [(2, 2)])
    assert sorted(map(tuple, np.argwhere(dot))) == [(1, 2), (2, 1), (2, 2), (2, 3), (3, 2)]
    assert not draw_guideline((5, 5), np.zeros((0, 2), int)).any()


@pytest.mark.parametrize("thickness", [1, 2, 3, 5])
def test_guideline_equals_cv2_line(thickness):
    rng = np.random.default_rng(thickness)
    for k in range(150):
        h, w = (int(v) for v in rng.integers(6, 60, 2))
        n = int(rng.integers(2, 6))
        pts = np.stack([rng.integers(0, h, n), rng.integers(0, w, n)], axis=1)
        np.testing.assert_array_equal(draw_guideline((h, w), pts, thickness), _cv2_polyline((h, w), pts, thickness),
                                      err_msg=f"{pts.tolist()} on {h}x{w}")
        # Sub-pixel end points behave like cv2.line(..., shift=16).
        fpts = pts + rng.integers(0, 4, pts.shape) / 4.0
        np.testing.assert_array_equal(draw_guideline((h, w), fpts, thickness),
                                      _cv2_polyline((h, w), fpts, thickness, shift=16), err_msg=f"{fpts.tolist()}")


def test_region_known_answer_and_cv2_semantics():
    guide = np.zeros((50, 60), bool)
    guide[20, 20] = True
    region = dilate_region(guide)
    # 14 px before and 15 after the guideline pixel: output (r, c) looks at rows r-15..r+14.
    want = np.zeros_like(guide)
    want[6:36, 6:36] = True
    np.testing.assert_array_equal(region, want)
    assert dilate_region(guide, 1).sum() == 1
    assert sorted(map(tuple, np.argwhere(dilate_region(guide, 2)))) == [(20, 20), (20, 21), (21, 20), (21, 21)]
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(0)
    for size in (2, 3, 30, 31):
        g = rng.random((70, 45)) < 0.01
        ref = cv2.dilate(g.astype(np.uint8), np.ones((size, size), np.uint8)) > 0
        np.testing.assert_array_equal(dilate_region(g, size), ref)


def test_near_optimal_path_and_labels_on_a_hand_made_map():
    obstacles = np.zeros((30, 40), bool)
    obstacles[10:30, 20] = True  # a wall from row 10 down; the way round is over its top end
    # On the open map the path is one straight segment.
    open_map = np.zeros_like(obstacles)
    np.testing.assert_array_equal(near_optimal_path(open_map, (25, 3), (2, 37)), [[25, 3], [2, 37]])
    # Around the wall: grid A*, then shortcut; every segment free, endpoints kept, shorter than A*.
    wp = near_optimal_path(obstacles, (25, 5), (25, 35))
    assert wp[0].tolist() == [25, 5] and wp[-1].tolist() == [25, 35]
    assert polyline_collisions(obstacles, wp) == []
    assert polyline_length(wp) <= shortest_path8(obstacles, (25, 5), (25, 35)).cost + 1e-9
    assert wp.min(axis=0)[0] <= 9  # it goes over the wall's top end (row 9 or above)
    labels = make_labels(obstacles, (25, 5), (25, 35))
    assert isinstance(labels, Labels)
    np.testing.assert_array_equal(labels.waypoints, wp)
    np.testing.assert_array_equal(labels.guideline, draw_guideline(obstacles.shape, wp))
    np.testing.assert_array_equal(labels.region, dilate_region(labels.guideline))
    assert labels.guideline.dtype == bool and labels.region.dtype == bool
    assert labels.guideline[25, 5] and labels.guideline[25, 35] and (labels.region >= labels.guideline).all()
    with pytest.raises(PointError):
        make_labels(obstacles, (15, 20), (0, 0))
    walled = obstacles.copy()
    walled[:, 20] = True
    with pytest.raises(NoPathError):
        make_labels(walled, (25, 5), (25, 35))


# The oracle's hand-made grid: 10 x 16 cells, a wall in column 7 over rows 0..8 (the gap is row 9).
# From (0, 6) to (0, 8) the only optimal path runs down column 6, through the gap, up column 8 (a
# diagonal would need a compensating one, 2 sqrt(2) > 2). Shortcut: (0, 6) sees (9, 6) straight down
# but nothing later (every later segment crosses the wall column above row 9); (9, 6) sees (9, 8)
# along row 9; (9, 8) sees the goal straight up.
ORACLE_GRID = np.zeros((10, 16), bool)
ORACLE_GRID[0:9, 7] = True
ORACLE_WAYPOINTS = [[0, 6], [9, 6], [9, 8], [0, 8]]


def _oracle_guideline_by_hand() -> np.ndarray:
    # At 4 px per cell, cell k has its centre at 4k + 1.5. A thickness-2 segment between centres on
    # one column 4k + 1.5 covers columns 4k + 1 .. 4k + 3 (edges at +-1 px, rounded up at .5) over
    # rows 4i + 2 .. 4j + 2, with a plus-shaped cap at each rounded centre (4i + 2, 4k + 2): one
    # extra pixel beyond each end. Rows and columns swap for a horizontal segment.
    g = np.zeros((40, 64), bool)
    g[2:39, 25:28] = True          # down column 6 (centre 25.5): rows 2..38, cols 25..27
    g[1, 26] = g[39, 26] = True    # its caps beyond the ends
    g[37:40, 26:35] = True         # along row 9 (centre 37.5): rows 37..39, cols 26..34
    g[38, 25] = g[38, 35] = True   # its caps
    g[2:39, 33:36] = True          # up column 8 (centre 33.5): rows 2..38, cols 33..35
    g[1, 34] = g[39, 34] = True
    return g


def test_oracle_prediction_equals_hand_computed_arrays():
    np.testing.assert_array_equal(near_optimal_path(ORACLE_GRID, (0, 6), (0, 8)), ORACLE_WAYPOINTS)
    np.testing.assert_array_equal(cell_centres([[0, 6], [9, 8]], 4), [[1.5, 25.5], [37.5, 33.5]])
    region, guide = oracle_prediction(ORACLE_GRID, (0, 6), (0, 8), px_per_cell=4)
    assert region.shape == guide.shape == (40, 64)
    assert region.dtype == guide.dtype == np.float32
    assert set(np.unique(region)) <= {0.0, 1.0} and set(np.unique(guide)) <= {0.0, 1.0}
    want_guide = _oracle_guideline_by_hand()
    np.testing.assert_array_equal(guide.astype(bool), want_guide)
    # Region: every guideline pixel (r, c) sets rows r-14..r+15 and columns c-14..c+15. The guideline
    # spans rows 1..39 (so all 40 rows) and columns 25..35 with the cap at column 35 on row 38 and
    # the columns 25..27 / 33..35 on every row 2..38: columns 11..50 on every row.
    want_region = np.zeros((40, 64), bool)
    want_region[:, 11:51] = True
    np.testing.assert_array_equal(region.astype(bool), want_region)
    # Cross-check the hand-made guideline against OpenCV at sub-pixel positions.
    centres = cell_centres(np.array(ORACLE_WAYPOINTS), 4)
    np.testing.assert_array_equal(want_guide, _cv2_polyline((40, 64), centres, 2, shift=16))


def test_oracle_other_scales_and_errors():
    region, guide = oracle_prediction(ORACLE_GRID, (0, 6), (0, 8), px_per_cell=1)
    assert guide.shape == (10, 16)
    np.testing.assert_array_equal(guide.astype(bool), draw_guideline((10, 16), ORACLE_WAYPOINTS))
    with pytest.raises(NoPathError):
        blocked = ORACLE_GRID.copy()
        blocked[9, 7] = True
        oracle_prediction(blocked, (0, 6), (0, 8))
    with pytest.raises(PointError):
        oracle_prediction(ORACLE_GRID, (0, 7), (0, 8))
    with pytest.raises(NdrqlError):
        oracle_prediction(ORACLE_GRID, (0, 6), (0, 8), px_per_cell=0)


@pytest.mark.data
@pytest.mark.parametrize("split", ["train", "seen", "unseen"])
def test_labels_reproduce_the_dataset_exactly(dataset_root, split):
    # The dataset's guideline is our drawing of its own waypoints, and its region our dilation of its
    # guideline, pixel for pixel (all 14,400 / 14,100 are checked by `ndrql reproduce labels`).
    from ndrql.dataset.layout import load_sample

    for index in (0, 299, 300, 650, 899, 905, 1199):
        if split == "train":
            index *= 10
        s = load_sample(dataset_root, split, index)
        np.testing.assert_array_equal(draw_guideline(s.map.shape, s.waypoints), s.guideline, err_msg=f"{split} {index}")
        if s.region_original is None:
            np.testing.assert_array_equal(dilate_region(s.guideline), s.region, err_msg=f"{split} {index}")


def _check_pair(obstacles, pair, min_dist_frac=0.75):
    h, w = obstacles.shape
    (sr, sc), (gr, gc) = pair
    assert all(isinstance(v, int) for v in (sr, sc, gr, gc))
    assert not obstacles[sr, sc] and not obstacles[gr, gc]
    assert sr <= (h - 1) / 2 <= gr  # start in the top half, goal in the bottom half
    mid = (w - 1) / 2
    assert (sc <= mid <= gc) or (gc <= mid <= sc)  # opposite column halves
    assert math.hypot(gr - sr, gc - sc) >= min_dist_frac * max(h, w)
    assert shortest_path8(obstacles, (sr, sc), (gr, gc)).path  # joined on the full map


def test_sample_endpoints_on_an_open_map():
    obstacles = np.zeros((201, 201), bool)
    pairs = [sample_endpoints(np.random.default_rng(seed), obstacles) for seed in range(20)]
    for pair in pairs:
        _check_pair(obstacles, pair)
    assert sample_endpoints(np.random.default_rng(3), obstacles) == pairs[3]  # same seed, same pair
    assert len(set(pairs)) == len(pairs)  # seed + 1 differs
    assert {p[0][1] < 100 for p in pairs} == {True, False}  # starts on both sides


def test_sample_endpoints_on_a_map_with_a_wall():
    obstacles = np.zeros((120, 90), bool)  # non-square: the distance uses max(H, W) = 120
    obstacles[60, :80] = True  # a wall with a gap on the right
    obstacles[20:40, 30:60] = True
    for seed in range(20):
        pair = sample_endpoints(np.random.default_rng(seed), obstacles)
        _check_pair(obstacles, pair)
    # A start sealed off from the bottom half is never paired: the top-left pocket below has no goal.
    pocket = np.zeros((100, 100), bool)
    pocket[48:51, :] = True  # the two halves are separated ...
    pocket[48:51, 95:] = False  # ... except through a gap on the far right
    pocket[:20, 20] = True
    pocket[20, :21] = True  # and a sealed pocket in the top-left corner
    for seed in range(10):
        (sr, sc), goal = sample_endpoints(np.random.default_rng(seed), pocket)
        assert not (sr < 20 and sc < 20)
        _check_pair(pocket, ((sr, sc), goal))


def test_sample_endpoints_none_when_no_pair():
    blocked = np.zeros((100, 100), bool)
    blocked[49:51, :] = True  # top and bottom halves are not joined
    assert sample_endpoints(np.random.default_rng(0), blocked, tries=20) is None
    assert sample_endpoints(np.random.default_rng(0), np.ones((50, 50), bool)) is None
    assert sample_endpoints(np.random.default_rng(0), np.zeros((50, 50), bool), min_dist_frac=1.5) is None
    for bad in (dict(min_dist_frac=-1.0), dict(min_dist_frac=float("nan")), dict(tries=0)):
        with pytest.raises(NdrqlError):
            sample_endpoints(np.random.default_rng(0), np.zeros((50, 50), bool), **bad)
