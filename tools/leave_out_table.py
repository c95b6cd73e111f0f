"""The leave-families-out table from the transfer reports of ``tools/leave_out.sh``.

For every family and planning grid: the reference run's numbers (trained on all families) and those
of the run that never saw the family, from the same maps and seeds, and the drop between them.

    python tools/leave_out_table.py results/leave-out > leave_out.md
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ndrql.experiments.report import md_table
from ndrql.experiments.transfer_report import MODEL, summarize

REFERENCE = "lofo-none"


def load(folder: Path) -> list[dict]:
    return json.loads((folder / "summary.json").read_text())["records"]


def excluded_by(out: Path) -> dict[str, str]:
    """family -> the run that left it out (run folders are ``lofo-<fam>-<fam>-...``)."""
    runs = {}
    for d in sorted(out.glob("lofo-*")):
        if d.name == REFERENCE or not (d / "summary.json").is_file():
            continue
        for fam in _split(d.name.removeprefix("lofo-")):
            runs[fam] = d.name
    return runs


def _split(text: str) -> list[str]:
    from ndrql.synth.families import family_names

    known = sorted(family_names(), key=len, reverse=True)  # gaps_blocks before gaps
    out, rest = [], text.replace(",", "-")
    while rest:
        fam = next((f for f in known if rest == f or rest.startswith(f + "-")), None)
        if fam is None:
            raise SystemExit(f"cannot read the families of run {text!r}")
        out.append(fam)
        rest = rest[len(fam) + 1:]
    return out


def _pct(s: dict, key: str) -> str:
    return f"{100 * (s['rows'][MODEL][key]['ratio'] - 1):+.1f}%"


def _wins(s: dict) -> str:
    return f"{100 * s['rows'][MODEL]['against_iql']['win_share']:.0f}%"


def table(out: Path) -> str:
    ref = load(out / REFERENCE)
    runs = excluded_by(out)
    grids = sorted({r["n"] for r in ref})
    head = ["family", "left out in", "grid", "maps", "region F1 (all / without)", "share of oracle (all / without)",
            "NDR-QL vs QL, geomean (all / without)", "clear wins over IQL (all / without)"]
    rows = []
    for fam in sorted(runs):
        other = load(out / runs[fam])
        for n in grids:
            a = summarize([r for r in ref if r["n"] == n and r["family"] == fam])
            b = summarize([r for r in other if r["n"] == n and r["family"] == fam])
            if not a["maps"] or not b["maps"]:
                rows.append([fam, runs[fam], str(n), "0"] + ["-"] * 4)
                continue
            rows.append([fam, runs[fam].removeprefix("lofo-"), str(n), str(a["maps"]),
                         f"{a['region_f1']:.1f} / {b['region_f1']:.1f} ({b['region_f1'] - a['region_f1']:+.1f})",
                         f"{100 * a['share']:.0f}% / {100 * b['share']:.0f}% ({100 * (b['share'] - a['share']):+.0f} pt)",
                         f"{_pct(a, 'vs_ql')} / {_pct(b, 'vs_ql')}",
                         f"{_wins(a)} / {_wins(b)}"])
    return md_table(head, rows) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=Path, help="the OUT folder of tools/leave_out.sh (one transfer report per run)")
    args = ap.parse_args(argv)
    if not (args.out / REFERENCE / "summary.json").is_file():
        print(f"leave_out_table: no reference report {args.out / REFERENCE / 'summary.json'}", file=sys.stderr)
        return 2
    sys.stdout.write(table(args.out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
