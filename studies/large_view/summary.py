#!/usr/bin/env python3
"""Tabulate ``measure.py``'s records: one row per view.

    PYTHONPATH=src python studies/large_view/summary.py ~/.cache/ndrql/studies/large_view/dev128

Columns: maps measured (skipped: start and goal apart on the safe grid), the share of maps where the
prediction is uninformative (Eq. 7 threshold below 0.5 or none: ``plan`` falls back to IQL), median
region F1 and path recall against the oracle, median forward time; on the planned subsample the geometric
means over maps of NDR-QL / IQL steps (mean over seeds per map) raw and with plan's fallback (an
uninformative map takes IQL's steps), the oracle's, the model's share of the oracle's gain
``(1 - NDR/IQL) / (1 - oracle/IQL)``, and the maps where NDR-QL took over 1.1x IQL's steps.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np


def geo(values: list[float]) -> float:
    return float(np.exp(np.mean(np.log(values)))) if values else float("nan")


def load(root: Path) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted(root.glob("*.json"))]


def table(records: list[dict]) -> str:
    done = [r for r in records if not r["skipped"]]
    views = list(done[0]["views"]) if done else []
    planned = [r for r in done if "steps" in r]
    lines = [f"{len(done)} maps measured, {len(records) - len(done)} skipped (start and goal apart at this grid); "
             f"{len(planned)} planned",
             "| view | input px | uninformative | region F1 (median) | path recall (median) | forward s (median) "
             "| NDR/IQL | with fallback | oracle/IQL | share of oracle gain | NDR > 1.1x IQL |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    oracle = [np.mean(r["steps"]["oracle"]) / np.mean(r["steps"]["IQL"]) for r in planned]
    for v in views:
        rows = [r["views"][v] for r in done]
        un = sum(x["uninformative"] for x in rows)
        raw = [np.mean(r["steps"][v]) / np.mean(r["steps"]["IQL"]) for r in planned]
        fb = [1.0 if r["views"][v]["uninformative"] else q for r, q in zip(planned, raw)]
        share = (1 - geo(fb)) / (1 - geo(oracle)) if planned and geo(oracle) < 1 else float("nan")
        sides = sorted({x["side"] for x in rows})
        lines.append(f"| {v} | {'/'.join(map(str, sides))} | {un}/{len(rows)} ({100 * un / max(1, len(rows)):.0f} %) "
                     f"| {np.median([x['f1'] for x in rows]):.2f} | {np.median([x['path_recall'] for x in rows]):.2f} "
                     f"| {np.median([x['seconds'] for x in rows]):.2f} | {geo(raw):.2f} | {geo(fb):.2f} | {geo(oracle):.2f} "
                     f"| {100 * share:.0f} % | {sum(q > 1.1 for q in raw)}/{len(raw)} |")
    return "\n".join(lines)


def by_family(records: list[dict]) -> str:
    """Per family: maps uninformative under each view, and on the planned maps NDR-QL / IQL with plan's
    fallback (geometric mean over the family's planned maps; oracle / IQL last)."""
    done = [r for r in records if not r["skipped"]]
    views = list(done[0]["views"]) if done else []
    lines = ["| family | maps | " + " | ".join(f"{v} uninf." for v in views) + " | planned | "
             + " | ".join(f"{v} NDR/IQL" for v in views) + " | oracle/IQL |",
             "|---|---:|" + "---:|" * (2 * len(views) + 2)]
    for fam in dict.fromkeys(r["family"] for r in done):
        rows = [r for r in done if r["family"] == fam]
        planned = [r for r in rows if "steps" in r]
        iql = [np.mean(r["steps"]["IQL"]) for r in planned]
        ratio = [geo([1.0 if r["views"][v]["uninformative"] else np.mean(r["steps"][v]) / q
                      for r, q in zip(planned, iql)]) for v in views]
        lines.append(f"| {fam} | {len(rows)} | " + " | ".join(
            str(sum(r["views"][v]["uninformative"] for r in rows)) for v in views) + f" | {len(planned)} | "
            + " | ".join(f"{x:.2f}" for x in ratio)
            + f" | {geo([np.mean(r['steps']['oracle']) / q for r, q in zip(planned, iql)]):.2f} |")
    return "\n".join(lines)


if __name__ == "__main__":
    for arg in sys.argv[1:]:
        recs = load(Path(arg).expanduser())
        print(f"## {arg}\n\n{table(recs)}\n\n{by_family(recs)}\n")
