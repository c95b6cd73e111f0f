"""Rule 1 of studies/judge/README.md: what each mechanism of the old large-grid chain bought against IQL-BFS.

Reads the records of ``ndrql reproduce transfer`` runs made at 2f11ade (``run_old.sh``) and prints, per grid and
per mechanism that served (the companion alone, the base model's second opinion, the relay, the propagating head,
or nothing: uninformative), the maps, NDR-QL (model) / IQL (BFS distance) in geometric mean, and the prediction's
median and maximum seconds.

    python studies/judge/ablation.py /work/runs/old-large-dev2-128-general/summary.json ...
"""

from __future__ import annotations

import json
import sys

import numpy as np

MODEL, BFS = "NDR-QL (model)", "IQL (BFS distance)"


def served_by(record: dict) -> str:
    """Which mechanism's prediction NDR-QL ran with on this case."""
    so = record.get("second_opinion")
    if not so:
        return "companion alone" if record["n"] > 128 else "model alone"
    if so.get("served"):
        return "base (second opinion)"
    relay = so.get("relay") or {}
    if relay.get("served"):
        return "relay" + (" (turned)" if relay.get("turned") else "")
    head = so.get("propagated") or {}
    if head.get("served"):
        return "propagating head"
    return "nothing served"


def main(paths: list[str]) -> None:
    for path in paths:
        recs = [r for r in json.load(open(path))["records"] if not r["skipped"]]
        groups: dict[str, list[dict]] = {}
        for r in recs:
            groups.setdefault(served_by(r), []).append(r)
        print(f"\n{path}: {len(recs)} maps")
        print("| served by | maps | NDR-QL / IQL-BFS (geo.) | prediction s, median | max |")
        print("|---|---:|---:|---:|---:|")
        for name, rs in sorted(groups.items()):
            ratio = np.exp(np.mean([np.log(np.mean(r["runs"][MODEL]["steps"]) / np.mean(r["runs"][BFS]["steps"]))
                                    for r in rs]))
            sec = [r["seconds"]["prediction"] for r in rs]
            print(f"| {name} | {len(rs)} | {ratio:.3f} | {np.median(sec):.2f} | {max(sec):.2f} |")


if __name__ == "__main__":
    main(sys.argv[1:])
