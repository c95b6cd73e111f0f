"""The rule of history.md#low-thresholds-on-large-grids applied to transfer summaries written with each cut
(``cut_transfer.py``): per cut, pooled over the sets given, the maps ``plan`` calls uninformative, its steps
against IQL's (geometric mean, those maps at IQL's steps) and the families where it is slower than IQL; then
the cut the rule picks (fewest steps among the cuts with no family slower; within 2% of the best, the highest)::

    PYTHONPATH=src python studies/large_view/cut_choice.py 0.1=DIR-A/summary.json,DIR-B/summary.json 0.05=...
"""

from __future__ import annotations

import argparse
import json
import math
from collections import defaultdict
from pathlib import Path

from ndrql.experiments.transfer_report import MODEL, uninformative

#: Cuts within this fraction of the fewest steps count as equal; the highest of them is taken.
TOLERANCE = 0.02


def _mean(xs: list[float]) -> float:
    return sum(xs) / len(xs)


def _geomean(xs: list[float]) -> float:
    return math.exp(sum(math.log(x) for x in xs) / len(xs))


def judge(records: list[dict], cut: float) -> dict:
    """``plan``'s figures for one cut over planned records: maps, uninformative count, geometric mean of its
    steps over IQL's, and per family that ratio (families above 1 are slower than IQL)."""
    ratios, fams = [], defaultdict(list)
    unin = 0
    for r in records:
        iql = _mean(r["runs"]["IQL"]["steps"])
        off = uninformative(r, cut)
        unin += off
        x = 1.0 if off else _mean(r["runs"][MODEL]["steps"]) / iql
        ratios.append(x)
        fams[r["family"]].append(x)
    per_family = {f: _geomean(v) for f, v in sorted(fams.items())}
    return {"cut": cut, "maps": len(records), "uninformative": unin, "plan": _geomean(ratios),
            "slower": {f: g for f, g in per_family.items() if g > 1.0}, "per_family": per_family}


def choose(results: list[dict]) -> dict | None:
    """The rule: among cuts with no family slower, those within :data:`TOLERANCE` of the fewest steps; the highest."""
    ok = [r for r in results if not r["slower"]]
    if not ok:
        return None
    best = min(r["plan"] for r in ok)
    return max((r for r in ok if r["plan"] <= best * (1 + TOLERANCE)), key=lambda r: r["cut"])


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", help="CUT=SUMMARY[,SUMMARY...]: the summaries written with that cut")
    a = ap.parse_args(argv)
    results = []
    for spec in a.runs:
        cut, paths = spec.split("=", 1)
        records = [r for p in paths.split(",") for r in json.loads(Path(p).read_text())["records"]
                   if not r.get("skipped") and MODEL in r.get("runs", {})]
        results.append(judge(records, float(cut)))
    print("| cut | maps | uninformative | `plan` / IQL | families slower than IQL |")
    print("|---:|---:|---:|---:|---|")
    for r in results:
        slow = ", ".join(f"`{f}` {g:.2f}" for f, g in r["slower"].items()) or "none"
        print(f"| {r['cut']:g} | {r['maps']} | {r['uninformative']} ({r['uninformative'] / r['maps']:.0%}) | "
              f"{r['plan']:.3f} | {slow} |")
    pick = choose(results)
    print(f"\nthe rule picks: {'no cut (every cut has a family slower than IQL)' if pick is None else pick['cut']}")


if __name__ == "__main__":
    main()
