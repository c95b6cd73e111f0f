#!/usr/bin/env python3
"""Issue 54's floors on the maps of several ``reproduce partial`` reads pooled (one candidate, several sealed sets).

Each records file (``records.jsonl`` of a run, or its ``.json.gz`` copy in ``docs/release/records``) is joined on
its own (the truth's rows to the belief's, :func:`ndrql.experiments.partial_report.joined`), then the groups of one
setting are pooled and summarised as the release report does (:func:`group_summary`, :func:`floors`).

    PYTHONPATH=src python studies/partial/pooled.py docs/release/records/run-29-sealed-partial-d.json.gz \
        docs/release/records/run-30-sealed-partial-e.json.gz --belief blobs:0.3
    PYTHONPATH=src python studies/partial/pooled.py --paired A/records.jsonl B/records.jsonl --sense on
"""

from __future__ import annotations

import argparse
import gzip
import json
import sys
from pathlib import Path

import numpy as np

from ndrql.experiments.partial_report import floors, group_summary, joined
from ndrql.experiments.stats import geomean_ratio, outcomes


def read_records(path: str) -> list[dict]:
    raw = Path(path).read_bytes()
    text = gzip.decompress(raw).decode() if path.endswith(".gz") else raw.decode()
    return [json.loads(line) for line in text.splitlines() if line.strip()]


def paired(args) -> int:
    """``--paired A B``: NDR-QL's mean steps in run A over those in run B on the same maps (one setting), per grid
    and over the grids together, with the 95% bootstrap interval and clear wins / ties / losses."""
    if len(args.records) != 2:
        raise SystemExit("--paired takes two records files")
    sense = args.sense == "on"
    runs = [{(r["index"], r["grid"]): r for r in read_records(p) if r.get("belief") == args.belief
             and bool(r.get("sense")) == sense and "NDR-QL" in r.get("rows", {})} for p in args.records]
    grids = [int(g) for g in args.grids.split(",")]
    for label, gs in [(f"grid {g}", [g]) for g in grids] + [("pooled grids", grids)]:
        keys = sorted(k for k in runs[0] if k in runs[1] and k[1] in gs)
        a = [runs[0][k]["rows"]["NDR-QL"]["steps"] for k in keys]
        b = [runs[1][k]["rows"]["NDR-QL"]["steps"] for k in keys]
        g = geomean_ratio([float(np.mean(x)) for x in a], [float(np.mean(x)) for x in b])
        o = outcomes(a, b)
        print(f"{args.belief}, sensing {args.sense}, {label}: {len(keys)} maps, NDR-QL A / B {g['ratio']:.3f} "
              f"({g['low']:.3f} .. {g['high']:.3f}), clear wins / ties / losses {o['wins']} / {o['ties']} / {o['losses']}")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("records", nargs="+")
    ap.add_argument("--belief", default="blobs:0.3")
    ap.add_argument("--sense", default="off", choices=("off", "on"))
    ap.add_argument("--grids", default="50,100")
    ap.add_argument("--paired", action="store_true",
                    help="two records files of one set: NDR-QL of the first / NDR-QL of the second, map by map")
    args = ap.parse_args(argv)
    if args.paired:
        return paired(args)
    sets = [joined(read_records(p)) for p in args.records]
    grids = [int(g) for g in args.grids.split(",")]
    sense = args.sense == "on"
    pick = lambda recs, gs: [r for r in recs if r["belief"] == args.belief and bool(r.get("sense")) == sense  # noqa: E731
                             and r["grid"] in gs]
    for label, gs in [(f"grid {g}", [g]) for g in grids] + [("pooled grids", grids)]:
        for name, recs in [(Path(p).name, s) for p, s in zip(args.records, sets)] + [("all sets", sum(sets, []))]:
            s = group_summary(pick(recs, gs))
            if not s.get("maps"):
                continue
            print(f"{args.belief}, sensing {args.sense}, {label}, {name}: {s['maps']} maps, headroom "
                  f"{s['headroom']:.1%}, NDR-QL / IQL-BFS {s['ndr']['ratio']:.3f}, share {s['share']:.0%}, "
                  f"worst {s['worst'][0]} {s['worst'][1]:.2f}")
            if name == "all sets":
                print("\n".join("  " + x for x in floors(s)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
