"""What the maps whose prediction is uninformative at 256 cells have in common: per map of a development transfer
report, the length of the optimal route on the planning grid and its detour (route over the Manhattan distance
of start and goal), tabulated against ``plan``'s verdict (history.md#floors-for-the-next-model-on-the-sealed-large-sets)::

    PYTHONPATH=src python studies/large_view/route_probe.py large-dev2-256=DIR/summary.json [SET=REPORT ...] [--grid 256]

Development sets only (the set is drawn again from its seed, which ``eval_spec`` refuses for a sealed one).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ndrql.experiments.ceiling import grid_case
from ndrql.experiments.eval_sets import eval_set, eval_spec
from ndrql.experiments.transfer import larger_sizes
from ndrql.experiments.transfer_report import uninformative
from ndrql.planning.runner import astar_length

LENGTH_EDGES = (0, 300, 500, 700, 1000, 10**6)
DETOUR_EDGES = (1.0, 1.1, 1.3, 1.6, 2.0, 10**6)


def route_rows(name: str, records: list[dict], grid: int) -> list[dict]:
    """Per planned record: family, route length (moves), detour and whether ``plan`` calls it uninformative."""
    gs = eval_set(eval_spec(name), False)
    rows = []
    for r in records:
        fam, i, _ = r["key"].rsplit("-", 2)
        raw = gs.raw(int(i))
        case = grid_case(r["key"], fam, raw.obstacles, raw.start, raw.goal, grid, larger_sizes(grid))
        length = astar_length(case.blocked, case.start_cell, case.goal_cell)
        manhattan = abs(case.start_cell[0] - case.goal_cell[0]) + abs(case.start_cell[1] - case.goal_cell[1])
        rows.append({"family": fam, "length": length, "detour": length / max(manhattan, 1),
                     "uninformative": uninformative(r)})
    return rows


def buckets(rows: list[dict], key: str, edges: tuple[float, ...]) -> list[tuple[str, int, int]]:
    """``(range, maps, uninformative)`` per bucket of ``key`` (empty buckets left out)."""
    out = []
    for lo, hi in zip(edges, edges[1:]):
        b = [r for r in rows if lo <= r[key] < hi]
        if b:
            out.append((f"{lo:g}-{hi:g}" if hi < 10**6 else f"{lo:g} or more", len(b), sum(r["uninformative"] for r in b)))
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", help="SET=REPORT: a development set and the summary.json of a transfer "
                    "report on it (several: pooled)")
    ap.add_argument("--grid", type=int, default=256)
    a = ap.parse_args(argv)
    rows = []
    for spec in a.runs:
        name, report = spec.split("=", 1)
        records = [r for r in json.loads(Path(report).read_text())["records"] if not r.get("skipped")]
        rows += route_rows(name, records, a.grid)
    for key, edges, label in (("length", LENGTH_EDGES, "route (moves)"), ("detour", DETOUR_EDGES, "detour")):
        print(f"| {label} | maps | uninformative |\n|---|---:|---:|")
        for rng, n, u in buckets(rows, key, edges):
            print(f"| {rng} | {n} | {u} ({u / n:.0%}) |")
        print()


if __name__ == "__main__":
    main()
