"""The relay (:mod:`ndrql.pipeline.relay`): where the companion and the base are both uninformative above 128
cells, the companion is asked again, for the same goal, from the cell of the start's region part that its own
distance puts nearest the goal, and the regions are joined. Checked with stand-in models whose regions depend
only on where they are asked from, so every hop is known."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from ndrql.pipeline.predictions import predict_on_grid, second_opinion_note
from ndrql.pipeline.relay import MAX_HOPS, TURNS, next_hop, relay, start_part, turned_relay
from ndrql.planning.config import PriorConfig

N = 160  # above fallback.LARGE_GRID: the cut 0.1 and the cover test apply
START, GOAL = (2, 2), (2, N - 3)
BLOCKED = np.zeros((N, N), bool)
DISTANCE = np.abs(np.arange(N)[None, :] - GOAL[1]) + np.abs(np.arange(N)[:, None] - GOAL[0]).astype(float)


def _seen(image: np.ndarray, start: tuple[int, int], goal: tuple[int, int], factor: int) -> SimpleNamespace:
    """What a stand-in model saw (the fields ``predict_on_grid`` reads of a ``ViewInput``)."""
    return SimpleNamespace(image=image, start=start, goal=goal, factor=factor)


@dataclass(frozen=True)
class _Out:
    region: np.ndarray
    guideline: np.ndarray
    distance: np.ndarray | None
    seen: SimpleNamespace


class _Reach:
    """A stand-in companion: asked from ``start`` it draws a 3-row band of 0.9 from the start's column ``reach``
    columns towards the goal (to the goal when it is within reach), with the Manhattan goal distance."""

    view = "cap:512"
    graph_file = None
    input_mode = "grid"

    def __init__(self, reach: int, distance: np.ndarray | None = DISTANCE):
        self.reach, self.distance, self.asked = reach, distance, []
        self.weights_file, self.merged_weights = Path("comp.pt"), None

    def predict_view(self, blocked, start, goal, companion: bool = True) -> _Out:
        self.asked.append(tuple(start))
        r = np.zeros((N, N))
        r[1:4, start[1]:min(N, start[1] + self.reach)] = 0.9
        return _Out(r, r * 0.5, self.distance, _seen(np.zeros((512, 512)), (1, 1), (2, 2), 1))

    def serving(self, n: int) -> "_Reach":
        return self


class _Base(_Reach):
    """A base whose own region never joins start and goal; every merged grid goes to ``companion``."""

    view = "coarse:128"

    def __init__(self, companion: _Reach):
        super().__init__(reach=1)
        self.companion, self.weights_file, self.merged_weights = companion, Path("base.pt"), companion.weights_file
        self.own = 0

    def serving(self, n: int) -> _Reach:
        return self.companion

    def predict_view(self, blocked, start, goal, companion: bool = True) -> _Out:
        if companion:
            return self.companion.predict_view(blocked, start, goal)
        self.own += 1
        r = np.zeros((N, N))
        r[START] = 0.9
        return _Out(r, r, None, _seen(np.zeros((640, 640)), (1, 1), (2, 2), 2))


def test_start_part_and_next_hop_follow_the_region_and_the_distance():
    region = np.zeros((N, N))
    region[1:4, 0:50] = 0.9
    region[1:4, 60:90] = 0.9  # a second piece, not joined to the start
    part = start_part(region, BLOCKED, START, 0.1)
    assert part.sum() == 3 * 50 and not part[2, 60]
    assert next_hop(part, DISTANCE) == (2, 49)  # the part's cell nearest the goal by the given distance
    assert not start_part(region, BLOCKED, (50, 50), 0.1).any() and next_hop(np.zeros((N, N), bool), DISTANCE) is None
    walled = BLOCKED.copy()
    walled[:, 20] = True
    assert start_part(region, walled, START, 0.1).sum() == 3 * 20  # an obstacle cuts the part


def test_the_relay_hops_from_where_the_region_ends_until_start_and_goal_join():
    comp = _Reach(reach=60)
    first = comp.predict_view(BLOCKED, START, GOAL)
    out, info = relay(comp, BLOCKED, START, GOAL, first, PriorConfig())
    # from (2, 2) the band reaches column 61; the next hop starts there, and so on to the goal
    assert info["hops"] == [[2, 61], [2, 120]] and info["served"] is True and info["reason"] is None
    assert comp.asked == [START, (2, 61), (2, 120)]
    assert (out.region[1:4, 2:] == 0.9).all() and out.region[5:, :].max() == 0.0  # the union of the three bands
    assert np.array_equal(out.distance, first.distance) and out.seen is first.seen


def test_the_relay_stops_after_max_hops_and_says_why_it_did_not_serve():
    comp = _Reach(reach=10)  # 160 columns need 15 hops
    first = comp.predict_view(BLOCKED, START, GOAL)
    out, info = relay(comp, BLOCKED, START, GOAL, first, PriorConfig())
    assert len(info["hops"]) == MAX_HOPS and info["served"] is False
    assert "no region threshold" in info["reason"]
    _, fewer = relay(_Reach(reach=10), BLOCKED, START, GOAL, first, PriorConfig(), max_hops=1)
    assert len(fewer["hops"]) == 1


def test_no_distance_or_no_way_on_means_no_hop():
    comp = _Reach(reach=10, distance=None)
    first = comp.predict_view(BLOCKED, START, GOAL)
    _, info = relay(comp, BLOCKED, START, GOAL, first, PriorConfig())
    assert info["hops"] == [] and info["served"] is False and comp.asked == [START]
    stuck = _Reach(reach=0)  # asked from anywhere it draws nothing: the start's part is empty
    _, info = relay(stuck, BLOCKED, START, GOAL, stuck.predict_view(BLOCKED, START, GOAL), PriorConfig())
    assert info["hops"] == []


def test_a_region_that_joins_but_covers_too_much_is_not_relayed():
    comp = _Reach(reach=N)
    wide = np.full((N, N), 0.9)  # joins start and goal over every cell: the cover test fails, hops cannot help
    first = _Out(wide, wide, DISTANCE, _seen(np.zeros((512, 512)), (1, 1), (2, 2), 1))
    _, info = relay(comp, BLOCKED, START, GOAL, first, PriorConfig())
    assert info["hops"] == [] and "covers" in info["reason"] and comp.asked == []


@pytest.mark.parametrize("reach,served", [(60, True), (10, False)])
def test_predict_on_grid_relays_only_after_the_base_was_asked_and_says_so(reach, served):
    base = _Base(_Reach(reach))
    region, _, info, _ = predict_on_grid(base, BLOCKED, START, GOAL)
    assert base.own == 1  # the second opinion came first
    so = info["second_opinion"]
    assert so["served"] is False and so["relay"]["served"] is served
    assert info["weights_file"] == "comp.pt" and info["companion"] is True
    note = second_opinion_note(info)
    assert "uninformative as well" in note
    if served:
        assert (region[1:4, 2:] == 0.9).all() and "asked again from 2 cells" in note and "joined start and goal" in note
    else:
        assert len(so["relay"]["hops"]) == MAX_HOPS and "did not join them" in note


def test_an_informative_companion_or_base_is_never_relayed():
    comp = _Reach(reach=N)
    region, _, info, _ = predict_on_grid(_Base(comp), BLOCKED, START, GOAL)
    assert "second_opinion" not in info and comp.asked == [START]


def test_the_report_line_counts_second_opinions_relays_and_hops():
    from ndrql.experiments.transfer_floors import second_opinion_line

    records = [{"skipped": False, "second_opinion": None},
               {"skipped": False, "second_opinion": {"asked_because": "x", "served": True, "reason": None}},
               {"skipped": False, "second_opinion": {"asked_because": "x", "served": False, "reason": "y",
                                                     "relay": {"hops": [[1, 2], [3, 4]], "served": True, "reason": None}}},
               {"skipped": False, "second_opinion": {"asked_because": "x", "served": False, "reason": "y",
                                                     "relay": {"hops": [[5, 6]], "served": False, "reason": "z"}}},
               {"skipped": False, "second_opinion": {"asked_because": "x", "served": False, "reason": "y",
                                                     "relay": {"hops": [], "served": False, "reason": "z"}}},
               {"skipped": True}]
    line = second_opinion_line(records)
    assert "asked on 4 of 5 maps, served on 1" in line
    assert "relayed (asked again from where its region ended) on 2 maps, 3 hops in all" in line
    assert line.endswith("served on 1")
    assert "relayed" not in second_opinion_line(records[:2])


class _Toward(_Reach):
    """A stand-in companion that draws its band from where it is asked ``reach`` columns towards the goal it is
    asked for (left or right), with the Manhattan distance to that goal: asked for the reversed problem it
    draws from the goal back towards the start."""

    def predict_view(self, blocked, start, goal, companion: bool = True) -> _Out:
        self.asked.append((tuple(start), tuple(goal)))
        r = np.zeros((N, N))
        step = 1 if goal[1] >= start[1] else -1
        end = start[1] + step * self.reach
        lo, hi = sorted((start[1], end))
        r[1:4, max(lo, 0):min(hi, N - 1) + 1] = 0.9
        dist = np.abs(np.arange(N)[None, :] - goal[1]) + np.abs(np.arange(N)[:, None] - goal[0]).astype(float)
        return _Out(r, r * 0.5, dist, _seen(np.zeros((512, 512)), (1, 1), (2, 2), 1))


def test_the_way_back_joins_what_the_hops_from_the_start_could_not():
    comp = _Toward(reach=20)  # 4 hops from the start reach about column 100 of 157; the way back covers the rest
    first = comp.predict_view(BLOCKED, START, GOAL)
    one_way, info1 = relay(_Toward(reach=20), BLOCKED, START, GOAL, first, PriorConfig(), back=False)
    assert info1["served"] is False and "back" not in info1 and len(info1["hops"]) == MAX_HOPS
    out, info = relay(comp, BLOCKED, START, GOAL, first, PriorConfig())
    assert info["hops"] == info1["hops"] and info["served"] is True and info["reason"] is None
    assert comp.asked[1 + MAX_HOPS] == (GOAL, START)  # the reversed problem, after the hops from the start
    assert all(goal == START for _, goal in comp.asked[2 + MAX_HOPS:])  # the way back's hops head for the start
    assert 1 <= len(info["back"]) <= MAX_HOPS and info["back"][0][1] < GOAL[1]
    assert (out.region[1:4, START[1]:GOAL[1] + 1] == 0.9).all()
    assert np.array_equal(out.distance, first.distance)  # Eq. 6 keeps the distance to the goal
    note = second_opinion_note({"second_opinion": {"asked_because": "x", "served": False, "reason": "y", "relay": info}})
    assert f"asked again from {MAX_HOPS} cells where its region ended and from the goal's side" in note
    assert "joined start and goal" in note


def test_the_report_line_counts_the_way_back():
    from ndrql.experiments.transfer_floors import second_opinion_line

    so = {"asked_because": "x", "served": False, "reason": "y",
          "relay": {"hops": [[1, 2]], "back": [[3, 4], [5, 6]], "served": True, "reason": None}}
    line = second_opinion_line([{"skipped": False, "second_opinion": so}])
    assert "relayed (asked again from where its region ended) on 1 maps, 3 hops in all (on 1 also from the goal's side)" in line


class _Turnable(_Reach):
    """A stand-in companion of one orientation whose average over four orientations reaches ``turned_reach``."""

    def __init__(self, reach: int, turned_reach: int, symmetries: int = 1):
        super().__init__(reach)
        self.turned_reach, self.symmetries, self.turns = turned_reach, symmetries, []

    def with_symmetries(self, count: int) -> "_Turnable":
        self.turns.append(count)
        return _Turnable(self.turned_reach, self.turned_reach, count)


@pytest.mark.parametrize("turned_reach,hops", [(N, 0), (60, 2)])
def test_four_orientations_serve_where_the_relay_of_one_failed(turned_reach, hops):
    comp = _Turnable(reach=10, turned_reach=turned_reach)
    first = comp.predict_view(BLOCKED, START, GOAL)
    out, info = turned_relay(comp, BLOCKED, START, GOAL, first, PriorConfig())
    assert comp.turns == [TURNS] and len(info["hops"]) == MAX_HOPS  # the relay of one orientation ran first
    turned = info["turned"]
    assert turned["orientations"] == TURNS and turned["served"] is True and len(turned["hops"]) == hops
    assert info["served"] is True and info["reason"] is None and "no region threshold" in turned["first_reason"]
    assert (out.region[1:4, 2:] == 0.9).all()  # the turned prediction (or its union) is what plan gets
    note = second_opinion_note({"second_opinion": {"asked_because": "x", "served": False, "reason": "y", "relay": info}})
    assert f"asked again from {MAX_HOPS} cells where its region ended" in note and "did not join them (no region" in note
    assert note.endswith(f"averaged over {TURNS} orientations of the grid" + (", asked again from 2 cells where its "
                         "region ended," if hops else "") + " it served")


def test_where_four_orientations_fail_too_nothing_changes():
    comp = _Turnable(reach=10, turned_reach=10)
    first = comp.predict_view(BLOCKED, START, GOAL)
    out, info = turned_relay(comp, BLOCKED, START, GOAL, first, PriorConfig())
    same, plain = relay(_Reach(reach=10), BLOCKED, START, GOAL, first, PriorConfig())
    assert np.array_equal(out.region, same.region) and info["served"] is False and info["reason"] == plain["reason"]
    assert info["turned"]["served"] is False and len(info["turned"]["hops"]) == MAX_HOPS
    note = second_opinion_note({"second_opinion": {"asked_because": "x", "served": False, "reason": "y", "relay": info}})
    assert "did not serve either (no region threshold" in note


def test_no_turn_where_the_relay_served_or_the_model_already_averages_four():
    served = _Turnable(reach=60, turned_reach=N)
    _, info = turned_relay(served, BLOCKED, START, GOAL, served.predict_view(BLOCKED, START, GOAL), PriorConfig())
    assert info["served"] is True and "turned" not in info and served.turns == []
    four = _Turnable(reach=10, turned_reach=N, symmetries=TURNS)
    _, info = turned_relay(four, BLOCKED, START, GOAL, four.predict_view(BLOCKED, START, GOAL), PriorConfig())
    assert info["served"] is False and "turned" not in info and four.turns == []


def test_the_report_line_counts_the_turns():
    from ndrql.experiments.transfer_floors import second_opinion_line

    relay_info = {"hops": [[1, 2]], "served": True, "reason": None,
                  "turned": {"orientations": 4, "hops": [], "served": True, "reason": None, "first_reason": "z"}}
    failed = {"hops": [[1, 2]], "served": False, "reason": "z",
              "turned": {"orientations": 4, "hops": [[3, 4]], "served": False, "reason": "z", "first_reason": "z"}}
    records = [{"skipped": False, "second_opinion": {"asked_because": "x", "served": False, "reason": "y", "relay": r}}
               for r in (relay_info, failed)]
    line = second_opinion_line(records)
    assert "relayed (asked again from where its region ended) on 2 maps, 2 hops in all, and its joined regions served on 0" in line
    assert line.endswith("averaged over 4 orientations was asked on 2 maps (relayed on 1) and served on 1")
