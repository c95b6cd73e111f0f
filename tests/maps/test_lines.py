"""Supercover, line of sight and shortcutting (ndrql.maps.lines): exact answers and invariants."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ndrql.errors import PointError
from ndrql.maps.astar import shortest_path8
from ndrql.maps.lines import (
    EPS,
    polyline_collisions,
    polyline_length,
    segment_free,
    segment_pixels,
    shortcut,
)

HALF = Fraction(1, 2)


def _touches(p0, p1, r: int, c: int, grow: Fraction = Fraction(0)) -> bool:
    """Exact reference: does the closed segment meet the closed square of pixel (r, c) (grown by ``grow``)?

    Liang-Barsky clipping in rational arithmetic (floats convert to Fractions exactly), so ties at
    corners and edges are decided without rounding.
    """
    (r0, c0), (r1, c1) = [(Fraction(p[0]), Fraction(p[1])) for p in (p0, p1)]
    t_lo, t_hi = Fraction(0), Fraction(1)
    for start, delta, centre in ((r0, r1 - r0, r), (c0, c1 - c0, c)):
        lo, hi = centre - HALF - grow, centre + HALF + grow
        if delta == 0:
            if not lo <= start <= hi:
                return False
            continue
        a, b = (lo - start) / delta, (hi - start) / delta
        t_lo, t_hi = max(t_lo, min(a, b)), min(t_hi, max(a, b))
        if t_lo > t_hi:
            return False
    return True


def _brute_supercover(p0, p1, grow: Fraction = Fraction(0)) -> set[tuple[int, int]]:
    rows = range(math.floor(min(p0[0], p1[0])) - 1, math.ceil(max(p0[0], p1[0])) + 2)
    cols = range(math.floor(min(p0[1], p1[1])) - 1, math.ceil(max(p0[1], p1[1])) + 2)
    return {(r, c) for r in rows for c in cols if _touches(p0, p1, r, c, grow)}


def test_supercover_known_answers():
    # Through a pixel corner: all four pixels that share the corner (0.5, 0.5).
    assert [tuple(p) for p in segment_pixels((0, 0), (1, 1))] == [(0, 0), (0, 1), (1, 0), (1, 1)]
    # Along the edge between rows 0 and 1: both rows.
    assert sorted(map(tuple, segment_pixels((0.5, 0), (0.5, 2)))) == [(r, c) for r in (0, 1) for c in range(3)]
    # Centre to centre, crossing row boundaries at columns 0.75 and 2.25: two pixels per row, in travel order.
    assert [tuple(p) for p in segment_pixels((0, 0), (2, 3))] == [(0, 0), (0, 1), (1, 1), (1, 2), (2, 2), (2, 3)]
    assert [tuple(p) for p in segment_pixels((2, 3), (0, 0))] == [(2, 3), (2, 2), (1, 2), (1, 1), (0, 1), (0, 0)]
    # (0, 0) -> (1, 3) crosses row boundary 0.5 exactly at the corner column 1.5: both (0, 2) and (1, 1).
    assert [tuple(p) for p in segment_pixels((0, 0), (1, 3))] == [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (1, 3)]
    # A point on a corner lies in 4 squares; a point inside one pixel in 1.
    assert len(segment_pixels((2.5, 2.5), (2.5, 2.5))) == 4
    assert [tuple(p) for p in segment_pixels((2.2, 3.1), (2.2, 3.1))] == [(2, 3)]
    # Negative coordinates work (pixels off the map are still pixels).
    assert {tuple(p) for p in segment_pixels((-1, -1), (-1, 1))} == {(-1, -1), (-1, 0), (-1, 1)}


@pytest.mark.parametrize("kind", ["float", "half", "integer"])
def test_supercover_equals_brute_force_on_random_segments(kind):
    rng = np.random.default_rng({"float": 0, "half": 1, "integer": 2}[kind])
    for _ in range(500):
        if kind == "float":
            p = rng.uniform(-6, 14, 4)
        elif kind == "half":  # many exact corner and edge crossings
            p = rng.integers(-12, 28, 4) / 2.0
        else:
            p = rng.integers(-6, 14, 4).astype(float)
        p0, p1 = (float(p[0]), float(p[1])), (float(p[2]), float(p[3]))
        got = [tuple(int(v) for v in q) for q in segment_pixels(p0, p1)]
        assert len(got) == len(set(got)), (p0, p1)
        assert set(got) == _brute_supercover(p0, p1), (p0, p1)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(-20, 20, allow_nan=False), min_size=4, max_size=4))
def test_supercover_property(coords):
    # Adversarial floats (hypothesis hunts near-ties): never a touched pixel left out; an extra pixel
    # only when the segment misses it by less than 2 * EPS (the documented rounding allowance).
    p0, p1 = (coords[0], coords[1]), (coords[2], coords[3])
    got = {tuple(int(v) for v in q) for q in segment_pixels(p0, p1)}
    assert _brute_supercover(p0, p1) <= got <= _brute_supercover(p0, p1, Fraction(2 * EPS))
    assert got == {tuple(int(v) for v in q) for q in segment_pixels(p1, p0)}  # symmetric


def test_segment_free_and_collisions():
    obstacles = np.zeros((5, 6), dtype=bool)
    obstacles[1, 2] = True
    assert segment_free(obstacles, (0, 0), (0, 5))
    assert not segment_free(obstacles, (0, 0), (2, 4))  # the supercover passes (1, 2)
    # Through the obstacle's corner (0.5, 1.5) only: a collision (conservative line of sight, and the
    # diagonal step A* forbids without corner cutting).
    assert not segment_free(obstacles, (1, 1), (0, 2))
    assert not segment_free(obstacles, (0.5, 0), (0.5, 5))  # along its top edge
    assert segment_free(obstacles, (0.4, 0), (0.4, 5))
    assert not segment_free(obstacles, (0, 0), (0, 6))  # leaves the map
    assert not segment_free(obstacles, (-0.5, 0), (0, 0))  # touches pixel row -1, off the map
    assert segment_free(obstacles, (-0.4, 0), (0, 0))
    pts = [(0, 0), (0, 5), (4, 5), (0, 1), (0, 9)]
    assert polyline_collisions(obstacles, pts) == [(2, (1, 2)), (3, (0, 6))]
    with pytest.raises(PointError):
        segment_free(obstacles, (0, float("nan")), (1, 1))


def test_collisions_report_the_first_blocked_pixel_in_travel_order():
    obstacles = np.zeros((5, 8), dtype=bool)
    obstacles[2, 3] = obstacles[2, 5] = True
    assert polyline_collisions(obstacles, [(2, 0), (2, 7)]) == [(0, (2, 3))]
    assert polyline_collisions(obstacles, [(2, 7), (2, 0)]) == [(0, (2, 5))]
    assert polyline_collisions(obstacles, [(0, 0), (0, 7), (4, 7), (4, 9)]) == [(2, (4, 8))]


def test_shortcut_known_answer():
    obstacles = np.zeros((5, 7), dtype=bool)
    obstacles[1:5, 3] = True  # a wall from row 1 down, passable only through row 0
    path = np.array([(4, 0), (3, 0), (2, 0), (1, 1), (0, 2), (0, 3), (0, 4), (1, 5), (2, 6), (3, 6), (4, 6)])
    out = shortcut(obstacles, path)
    # (4,0)->(0,2) is free (misses (1,3)), (0,2)->(0,4) stays in row 0, (0,4)->(4,6) is free.
    assert out.tolist() == [[4, 0], [0, 2], [0, 4], [4, 6]]
    assert out.dtype == path.dtype
    assert polyline_collisions(obstacles, out) == []
    assert shortcut(obstacles, path[:2]).tolist() == path[:2].tolist()


def test_shortcut_keeps_an_already_blocked_segment_and_adds_none():
    obstacles = np.zeros((3, 5), dtype=bool)
    obstacles[1, 2] = True
    path = [(1, 0), (1, 1), (1, 3), (1, 4)]  # (1,1)->(1,3) crosses the obstacle
    out = shortcut(obstacles, path)
    assert out.tolist() == [[1, 0], [1, 1], [1, 3], [1, 4]]
    assert [i for i, _ in polyline_collisions(obstacles, out)] == [1]


def _random_map_path(seed: int):
    rng = np.random.default_rng(seed)
    h, w = (int(v) for v in rng.integers(8, 60, 2))
    obstacles = rng.random((h, w)) < rng.uniform(0.05, 0.4)
    free = np.argwhere(~obstacles)
    if len(free) < 2:
        return None
    s, g = (tuple(int(v) for v in free[i]) for i in rng.choice(len(free), 2, replace=False))
    try:
        return obstacles, np.array(shortest_path8(obstacles, s, g).path)
    except Exception:
        return None


@settings(max_examples=120, deadline=None)
@given(st.integers(0, 10**6))
def test_shortcut_never_introduces_a_collision(seed):
    case = _random_map_path(seed)
    if case is None:
        return
    obstacles, path = case
    assert polyline_collisions(obstacles, path) == []  # A* steps (no corner cutting) are free segments
    out = shortcut(obstacles, path)
    assert polyline_collisions(obstacles, out) == []
    assert out[0].tolist() == path[0].tolist() and out[-1].tolist() == path[-1].tolist()
    assert polyline_length(out) <= polyline_length(path) + 1e-9
    # Greedy farthest-visible: from each kept point no later input point beyond the next kept one is visible.
    index = {tuple(p): i for i, p in enumerate(path.tolist())}
    kept = [index[tuple(p)] for p in out.tolist()]
    for a, b in zip(kept, kept[1:]):
        assert b > a
        assert not any(segment_free(obstacles, path[a], path[j]) for j in range(b + 1, len(path)))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10**6))
def test_shortcut_on_float_polylines(seed):
    rng = np.random.default_rng(seed)
    obstacles = rng.random((30, 30)) < 0.15
    pts = np.cumsum(rng.uniform(-1.5, 1.5, (40, 2)), axis=0) + 15
    before = {i for i, _ in polyline_collisions(obstacles, pts)}
    out = shortcut(obstacles, pts)
    assert out.dtype == np.float64 and out[0].tolist() == pts[0].tolist() and out[-1].tolist() == pts[-1].tolist()
    assert polyline_length(out) <= polyline_length(pts) + 1e-9
    # Every blocked output segment is one of the input's own blocked segments, kept as it was.
    rows = [tuple(p) for p in pts.tolist()]
    for i, _ in polyline_collisions(obstacles, out):
        k = rows.index(tuple(out[i].tolist()))
        assert k in before and tuple(out[i + 1].tolist()) == rows[k + 1]


def test_polyline_length():
    assert polyline_length([(0, 0), (3, 4), (3, 10)]) == pytest.approx(11.0)
    assert polyline_length([(1, 1)]) == 0.0
