"""Belief masks drawn from a true map: blobs, what a robot sensed, an outdated map (ndrql.synth.masks)."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.synth import masks as M
from ndrql.synth.families import generate_map


def _rooms(side: int = 121) -> np.ndarray:
    """A bordered map with an inner wall at column 60 (a door at rows 55-64) and a block."""
    o = np.zeros((side, side), dtype=bool)
    o[0, :] = o[-1, :] = o[:, 0] = o[:, -1] = True
    o[:, 60] = True
    o[55:65, 60] = False
    o[20:30, 20:40] = True
    return o


def _free_point(o: np.ndarray, rng: np.random.Generator) -> tuple[int, int]:
    rr, cc = np.nonzero(~o)
    i = int(rng.integers(len(rr)))
    return int(rr[i]), int(cc[i])


@pytest.mark.parametrize("fraction", [0.1, 0.3, 0.5])
def test_blobs_hide_the_target_share_of_free_space(fraction):
    o = generate_map("rooms", np.random.default_rng(3), 201, 201)
    rng = np.random.default_rng(0)
    s, g = _free_point(o, rng), _free_point(o, rng)
    b = M.blobs(o, s, g, fraction, np.random.default_rng(7))
    free = int((~o).sum())
    assert abs(int((b.unknown & ~o).sum()) - round(fraction * free)) <= 1
    assert abs(b.unknown_share(o) - fraction) < 1e-3
    assert not b.obstacles[b.unknown].any()  # an unknown pixel is never a believed obstacle
    assert (b.obstacles == (o & ~b.unknown)).all()  # what is known is true


@pytest.mark.parametrize("kind", M.KINDS)
def test_start_goal_and_their_discs_stay_known(kind):
    o = generate_map("maze", np.random.default_rng(5), 201, 201)
    rng = np.random.default_rng(1)
    s, g = _free_point(o, rng), _free_point(o, rng)
    b = M.draw_belief(kind, o, s, g, np.random.default_rng(2), fraction=0.5)
    around = M.kept(o.shape, (s, g), None)
    assert around[s] and around[g] and around.sum() > 2
    assert not b.unknown[around].any()
    assert (b.obstacles[around] == o[around]).all()


@pytest.mark.parametrize("kind", M.KINDS)
def test_same_seed_same_belief_next_seed_another(kind):
    o = generate_map("office", np.random.default_rng(11), 201, 201)
    rng = np.random.default_rng(4)
    s, g = _free_point(o, rng), _free_point(o, rng)
    a = M.draw_belief(kind, o, s, g, np.random.default_rng(100))
    b = M.draw_belief(kind, o, s, g, np.random.default_rng(100))
    c = M.draw_belief(kind, o, s, g, np.random.default_rng(101))
    assert (a.unknown == b.unknown).all() and (a.obstacles == b.obstacles).all()
    assert (a.unknown != c.unknown).any() or (a.obstacles != c.obstacles).any()


def test_blobs_refuse_a_share_the_kept_discs_leave_no_room_for():
    o = np.zeros((20, 20), dtype=bool)
    with pytest.raises(ValueError, match="cannot hide"):
        M.blobs(o, (5, 5), (14, 14), 0.9, np.random.default_rng(0), keep=8)
    with pytest.raises(ValueError, match="fraction"):
        M.blobs(o, (5, 5), (14, 14), 1.0, np.random.default_rng(0))


def test_line_of_sight_stops_at_the_first_obstacle():
    o = np.zeros((41, 41), dtype=bool)
    o[10:31, 25] = True  # a wall right of the robot
    seen = M.visible_from(o, (20, 20), 15.0)
    assert seen[20, 24] and seen[20, 25]  # free up to the wall, and the wall itself
    assert not seen[20, 26:36].any()  # nothing behind it
    assert seen[20, 5] and seen[5, 20]  # open sides within the radius
    assert not seen[20, 4] and not seen[3, 20]  # beyond the radius
    assert seen[20, 20]


def test_sensed_knows_what_the_route_saw_and_not_behind_walls():
    o = _rooms()
    route = np.array([(r, 30) for r in range(90, 99)])  # a short drive in the left room, below the block
    b = M.sensed(o, (95, 30), (95, 90), [route], 12.0, keep=3)
    assert not b.unknown[90, 30] and not b.unknown[80, 30]  # on and near the route
    assert b.unknown[60, 30]  # out of range
    assert not b.unknown[95, 90] and b.unknown[95, 80]  # the goal's disc is known, the room around it not
    far = np.zeros_like(o)
    far[:, 61:] = True
    assert b.unknown[far & ~M.kept(o.shape, [(95, 90)], 3)].all()  # the right room was never seen


def test_sensed_behind_a_wall_stays_unknown_within_range():
    o = np.zeros((41, 41), dtype=bool)
    o[5:36, 20] = True
    b = M.sensed(o, (20, 15), (20, 35), [np.array([(20, 15)])], 10.0, keep=1)
    assert not b.unknown[20, 19] and not b.unknown[20, 20]
    assert b.unknown[20, 21] and b.unknown[20, 24]  # within 10 px of the robot but behind the wall


def test_sensing_routes_start_at_start_and_stay_free():
    o = _rooms()
    routes = M.sensing_routes(o, (95, 30), np.random.default_rng(0), count=3)
    assert len(routes) == 3
    for r in routes:
        assert tuple(r[0]) == (95, 30) and not o[r[:, 0], r[:, 1]].any()


def test_outdated_closes_gaps_and_opens_walls_nothing_unknown():
    o = _rooms()
    b = M.outdated(o, (95, 30), (95, 90), np.random.default_rng(0), closed=5, opened=5)
    assert not b.unknown.any()
    closed, opened = b.obstacles & ~o, ~b.obstacles & o
    assert closed.any() and opened.any()
    assert not (closed | opened)[M.kept(o.shape, [(95, 30), (95, 90)], None)].any()


def test_outdated_can_close_the_only_door():
    o = _rooms()
    o[20:30, 20:40] = False  # no block: the door is the only gap of width <= the limit
    for seed in range(20):
        b = M.outdated(o, (60, 30), (60, 90), np.random.default_rng(seed), closed=1, opened=0)
        if b.obstacles[55:65, 60].all():
            return
    pytest.fail("no seed of 20 closed the door")


def test_draw_belief_refuses_an_unknown_kind():
    with pytest.raises(ValueError, match="valid: blobs, sensed, outdated"):
        M.draw_belief("fog", np.zeros((9, 9), bool), (1, 1), (7, 7), np.random.default_rng(0))
