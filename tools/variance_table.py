"""Tables of the variance-over-training runs (``tools/variance_runs.sh``): how far the development figures
move with the model's training seed, and what leaving a group of related families out costs them.

Reads ``<dir>/<run>/summary.json`` of ``ndrql reproduce transfer`` for every run under ``dir``: the runs
``<prefix>-s<seed>`` (same recipe, other seed) and ``<prefix>-no-<families>`` (the recipe without those
families, seed 0). Prints markdown: one row per run (NDR-QL / IQL in the geometric mean of per-map
ratios with its bootstrap interval, clear wins / ties / losses, share of the oracle's gain, region F1),
the spread over seeds, and per left-out run the left-out families' ratio against the seed-0 run's.

    python tools/variance_table.py results/variance
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from ndrql.experiments.transfer_floors import family_ratios
from ndrql.experiments.transfer_report import MODEL, summarize
from ndrql.experiments.report import md_table


def load(run: Path) -> tuple[str, list[dict], int]:
    """The run's name (the folder's, without the ``-<preset>`` that ``reproduce transfer`` appends), the case
    records of its report and its grid (the first it was read at)."""
    data = json.loads((run / "summary.json").read_text())
    suffix = f"-{data.get('preset', '')}"
    name = run.name[:-len(suffix)] if data.get("preset") and run.name.endswith(suffix) else run.name
    return name, data["records"], int(data["grids"][0])


def row(name: str, records: list[dict], n: int) -> tuple[list[str], dict]:
    """A table row of one run at grid ``n`` and its summary."""
    s = summarize([r for r in records if r["n"] == n])
    d = s["rows"][MODEL]
    v, o = d["vs_iql"], d["against_iql"]
    cells = [name, str(s["maps"]), f"{v['ratio']:.3f} ({v['low']:.3f}-{v['high']:.3f})",
             f"{o['wins']} / {o['ties']} / {o['losses']}", f"{100 * s.get('share_geo_raw', math.nan):.0f}%",
             f"{s['region_f1']:.1f}", f"{d['path']['worst']:.3f}"]
    return cells, s


def left_out(name: str, prefix: str) -> list[str]:
    """The families a leave-out run's name says it left out (``<prefix>-no-a-b_c`` -> ``a``, ``b_c``)."""
    return name[len(prefix) + 4:].split("-")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir", type=Path, help="the reports' folder (tools/variance_runs.sh OUT)")
    ap.add_argument("--prefix", default="var", help="run name prefix (default: var)")
    args = ap.parse_args(argv)
    runs = sorted(p for p in args.dir.glob(f"{args.prefix}-*") if (p / "summary.json").exists())
    if not runs:
        print(f"variance_table: error: no {args.prefix}-* report with a summary.json under {args.dir}", file=sys.stderr)
        return 2
    head = ["run", "maps", "NDR-QL / IQL, geomean (95% CI)", "clear wins / ties / losses", "share of oracle's gain",
            "region F1", "worst path / A*"]
    rows, seeds, records = [], {}, {}
    for run in runs:
        name, recs, n = load(run)
        cells, s = row(name, recs, n)
        rows.append(cells)
        records[name] = [r for r in recs if r["n"] == n]
        if name[len(args.prefix) + 1:].startswith("s"):
            seeds[name] = s
    print(md_table(head, rows))
    if len(seeds) > 1:
        ratios = np.array([s["rows"][MODEL]["vs_iql"]["ratio"] for s in seeds.values()])
        shares = np.array([s.get("share_geo_raw", math.nan) for s in seeds.values()])
        f1 = np.array([s["region_f1"] for s in seeds.values()])
        print(f"\nOver the {len(seeds)} training seeds: NDR-QL / IQL {ratios.min():.3f}-{ratios.max():.3f} "
              f"(mean {ratios.mean():.3f}, sd {ratios.std(ddof=1):.3f}); share of the oracle's gain "
              f"{100 * shares.min():.0f}-{100 * shares.max():.0f}%; region F1 {f1.min():.1f}-{f1.max():.1f}.")
    ref = records.get(f"{args.prefix}-s0")
    for name, recs in records.items():
        if not name.startswith(f"{args.prefix}-no-") or ref is None:
            continue
        fams = left_out(name, args.prefix)
        a, b = family_ratios(ref), family_ratios(recs)
        out = [[f, f"{a[f]:.3f}", f"{b[f]:.3f}", f"{b[f] / a[f]:.2f}"] for f in fams if f in a and f in b]
        others = [f for f in a if f in b and f not in fams]
        gm = float(np.exp(np.mean([np.log(b[f] / a[f]) for f in others]))) if others else math.nan
        print(f"\n{name} against {args.prefix}-s0 (NDR-QL / IQL per family, with plan's fallback; families of the "
              f"set only):\n")
        print(md_table(["family left out", "seed-0 run", "left out", "change"], out))
        word = "family" if len(others) == 1 else "families"
        print(f"\nThe other {len(others)} {word}: {gm:.2f}x the seed-0 run's ratio (geometric mean).")
    return 0


if __name__ == "__main__":
    sys.exit(main())
