"""Doubts about a MovingAI scenario: a ``.scen`` written for another map, or an optimum no path can reach.

A ``.scen`` names its map; a scenario's optimal length can never be shorter than the octile distance
between its start and goal (the length with no obstacle at all). Either is worth a warning: the
runs still go, but their "x optimal" ratios would be measured against the wrong numbers.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

from ndrql.maps.readers import Scenario

#: Slack on the octile bound: ``.scen`` files round the optimum to 8 decimals.
OCTILE_SLACK = 1e-4


def octile_distance(start: Sequence[int], goal: Sequence[int]) -> float:
    """Length of the shortest 8-connected path between two pixels on an empty map."""
    dr, dc = abs(int(goal[0]) - int(start[0])), abs(int(goal[1]) - int(start[1]))
    return max(dr, dc) + (math.sqrt(2.0) - 1.0) * min(dr, dc)


def _printable(text: str) -> str:
    return text if text.isprintable() else repr(text)


def scenario_doubts(scenarios: Sequence[Scenario], map_source: str, scen_path: str | Path) -> list[str]:
    """Warnings (at most one per kind) about ``scenarios`` of ``scen_path`` used on the map ``map_source``."""
    doubts = []
    names = {Path(s.map.replace("\\", "/")).name for s in scenarios}
    mine = Path(str(map_source)).name
    others = sorted(n for n in names if n.lower() != mine.lower())
    if others and mine:
        doubts.append(f"{_printable(str(scen_path))} was written for the map {_printable(others[0][:80])}, not "
                      f"{_printable(mine[:80])}; its optimal lengths may not hold here")
    bad = [i for i, s in enumerate(scenarios) if s.optimal_length + OCTILE_SLACK < octile_distance(s.start, s.goal)]
    if bad:
        s = scenarios[bad[0]]
        doubts.append(f"{_printable(str(scen_path))}: {len(bad)} scenario(s) have an optimal length shorter than "
                      f"the straight octile distance (scenario {bad[0]}: {s.optimal_length:g} < "
                      f"{octile_distance(s.start, s.goal):.4f}); no path can be that short")
    return doubts
