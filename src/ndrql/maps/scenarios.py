"""Doubts about a MovingAI scenario: a ``.scen`` written for another map, or an optimum no path can reach.

A ``.scen`` names its map; a scenario's optimal length can never be shorter than the octile distance
between its start and goal (the length with no obstacle at all). Either is worth a warning: the
runs still go, but their "x optimal" ratios would be measured against the wrong numbers.

The octile check allows for the file's rounding: a length printed with ``d`` decimals may lie up to
half a unit of its last digit below the true one (MovingAI's own files print 8 decimals, many
converted ones 3), so the slack is ``0.5 * 10**-d`` (:func:`rounding_slack`) plus float noise.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

from ndrql.maps.readers import Scenario

#: Float noise on top of the rounding slack (and the whole slack when a length's precision is unknown).
OCTILE_SLACK = 1e-6


class ScenarioWarning(UserWarning):
    """A doubt about a MovingAI scenario (:func:`scenario_doubts`)."""


def octile_distance(start: Sequence[int], goal: Sequence[int]) -> float:
    """Length of the shortest 8-connected path between two pixels on an empty map."""
    dr, dc = abs(int(goal[0]) - int(start[0])), abs(int(goal[1]) - int(start[1]))
    return max(dr, dc) + (math.sqrt(2.0) - 1.0) * min(dr, dc)


def printed_decimals(scen_path: str | Path) -> list[int | None]:
    """Digits after the decimal point of each scenario's optimal length as the file prints it (the reader's
    :class:`Scenario` keeps the value only); ``None`` where the field is not a plain decimal (``1e-3``)."""
    try:
        text = Path(scen_path).read_text(encoding="utf-8", errors="replace")
    except OSError:
        return []
    out: list[int | None] = []
    for line in text.splitlines():
        parts = line.split("\t") if "\t" in line else line.split()
        if len(parts) != 9:  # the version line, blank lines (the reader refuses anything else)
            continue
        field = parts[8].strip().lower()
        out.append(len(field.partition(".")[2]) if "e" not in field else None)
    return out


def rounding_slack(decimals: int | None) -> float:
    """How far below the true optimum a length printed with ``decimals`` digits may lie: half a unit of its
    last digit (``None``, unknown: 1e-4), plus float noise."""
    return OCTILE_SLACK + (0.5 * 10.0 ** -decimals if decimals is not None else 1e-4)


def below_octile(scenario: Scenario, decimals: int | None = None) -> bool:
    """Whether the scenario's optimal length is shorter than the straight octile distance, beyond its rounding."""
    return scenario.optimal_length + rounding_slack(decimals) < octile_distance(scenario.start, scenario.goal)


def _printable(text: str) -> str:
    return text if text.isprintable() else repr(text)


def scenario_doubts(scenarios: Sequence[Scenario], map_source: str, scen_path: str | Path,
                    numbers: Sequence[int] | None = None) -> list[str]:
    """Warnings (at most one per kind) about ``scenarios`` of ``scen_path`` used on the map ``map_source``;
    ``numbers``: the scenarios' indices in the file, which the warnings name (default 0, 1, ...)."""
    numbers = list(range(len(scenarios))) if numbers is None else list(numbers)
    doubts = []
    names = {Path(s.map.replace("\\", "/")).name for s in scenarios}
    mine = Path(str(map_source)).name
    others = sorted(n for n in names if n.lower() != mine.lower())
    if others and mine:
        doubts.append(f"{_printable(str(scen_path))} was written for the map {_printable(others[0][:80])}, not "
                      f"{_printable(mine[:80])}; its optimal lengths may not hold here")
    printed = printed_decimals(scen_path) if any(below_octile(s, 12) for s in scenarios) else []  # read when in doubt
    bad = [k for k, s in zip(numbers, scenarios) if below_octile(s, printed[k] if 0 <= k < len(printed) else None)]
    if bad:
        s = scenarios[numbers.index(bad[0])]
        more = f"{len(bad)} scenarios ({', '.join(map(str, bad[:5]))}{', ...' if len(bad) > 5 else ''}) have" \
            if len(bad) > 1 else f"scenario {bad[0]} has"
        doubts.append(f"{_printable(str(scen_path))}: {more} an optimal length shorter than the straight octile "
                      f"distance (scenario {bad[0]}: {s.optimal_length:g} < {octile_distance(s.start, s.goal):.4f}, "
                      f"beyond the file's rounding); no path can be that short")
    return doubts
