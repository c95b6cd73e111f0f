"""The report of ``ndrql reproduce partial`` (:mod:`ndrql.experiments.partial`): markdown from the task records.

Per belief setting, sensing and grid: first the oracle's headroom over IQL-BFS (belief) (``1 - oracle / IQL-BFS``,
geometric mean over maps with a 95% bootstrap interval), then NDR-QL / IQL-BFS (belief) with the release report's
statistics (:mod:`ndrql.experiments.stats`: geometric mean and its interval, clear wins / ties / losses over seeds,
the share of the oracle's gain ``(1 - model) / (1 - oracle)``), IQL-NDR beside it with the same statistics (not
judged by the floors), which source served NDR-QL, every row per family,
path quality (learned path / A* on the true map) and the seconds of prediction and priors. Then the floors of issue
54 at blobs 30% without sensing (:data:`FLOORS`), each PASS or MISS.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any, Iterable

import numpy as np

from ndrql.experiments.partial import REF, ROWS, TRUTH_ROWS
from ndrql.experiments.stats import geomean_ratio, outcomes, share_of_oracle_geomean

#: The setting the floors are judged at (issue 54: 30% of the free space hidden in blobs, no sensing).
FLOOR_SETTING = ("blobs:0.3", False)
#: Issue 54's floors: NDR-QL / IQL-BFS at most this (geometric mean) ...
MAX_RATIO = 0.85
#: ... taking at least this share of the oracle's gain ...
MIN_SHARE = 0.40
#: ... and no family worse than IQL-BFS by more than this factor.
MAX_FAMILY = 1.05
#: Under this headroom of the oracle the issue asks only to say so (the feature ships, the floors do not apply).
MIN_HEADROOM = 0.15


def _mean(rec: dict, row: str) -> float:
    return float(np.mean(rec["rows"][row]["steps"]))


def joined(records: Iterable[dict]) -> list[dict]:
    """The belief records with the truth's rows (IQL, the oracle) of the same map and grid joined in."""
    records = list(records)
    truth = {(r["index"], r["grid"]): r for r in records if r.get("belief") is None and "rows" in r}
    out = []
    for r in records:
        if r.get("belief") is None or "rows" not in r:
            continue
        t = truth.get((r["index"], r["grid"]))
        rows = dict(r["rows"])
        if t is not None:
            rows.update({k: t["rows"][k] for k in TRUTH_ROWS if k in t["rows"]})
        out.append({**r, "rows": rows})
    return out


def _ratio(group: list[dict], row: str) -> dict[str, float]:
    return geomean_ratio([_mean(r, row) for r in group], [_mean(r, REF) for r in group])


def _pct(x: float) -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.0%}"


def _share_text(share: float, headroom: float) -> str:
    """The share of the oracle's gain, or why it is not given: under :data:`MIN_HEADROOM` the oracle's gain is too
    small for a share of it to mean anything (a 0.2% headroom turns a 6% loss into -3,000%)."""
    if headroom < MIN_HEADROOM:
        return f"not given (the oracle's headroom {headroom:.1%} is under {MIN_HEADROOM:.0%})"
    return _pct(share)


def _quantiles(values: list[float]) -> str:
    if not values:
        return "-"
    v = np.asarray(values, dtype=np.float64)
    return f"{np.median(v):.2f} / {np.percentile(v, 95):.2f} / {v.max():.2f}"


def group_summary(group: list[dict]) -> dict[str, Any]:
    """The figures of one group of maps (one setting, sensing and grid, or pooled): headroom, NDR-QL against
    IQL-BFS, the share of the oracle's gain, the worst family."""
    full = [r for r in group if REF in r["rows"] and "NDR-QL" in r["rows"] and "NDR-QL (oracle)" in r["rows"]]
    if not full:
        return {"maps": 0}
    orc, ndr = _ratio(full, "NDR-QL (oracle)"), _ratio(full, "NDR-QL")
    o_orc = outcomes([r["rows"]["NDR-QL (oracle)"]["steps"] for r in full], [r["rows"][REF]["steps"] for r in full])
    o_ndr = outcomes([r["rows"]["NDR-QL"]["steps"] for r in full], [r["rows"][REF]["steps"] for r in full])
    fams = {f: _ratio([r for r in full if r["family"] == f], "NDR-QL")["ratio"] for f in sorted({r["family"] for r in full})}
    worst = max(fams, key=fams.get)
    out = {"maps": len(full), "oracle": orc, "ndr": ndr, "oracle_outcomes": o_orc, "ndr_outcomes": o_ndr,
           "headroom": 1 - orc["ratio"], "share": share_of_oracle_geomean(ndr["ratio"], orc["ratio"]),
           "families": fams, "worst": (worst, fams[worst])}
    both = [r for r in full if "IQL-NDR" in r["rows"]]  # beside NDR-QL, not judged by the floors
    if both:
        iql = _ratio(both, "IQL-NDR")
        out["iql_ndr"] = {"maps": len(both), **iql, "share": share_of_oracle_geomean(iql["ratio"], orc["ratio"]),
                          "outcomes": outcomes([r["rows"]["IQL-NDR"]["steps"] for r in both],
                                               [r["rows"][REF]["steps"] for r in both])}
    return out


def floors(summary: dict[str, Any]) -> list[str]:
    """Issue 54's floors on one group's summary, each ``PASS`` or ``MISS`` (or the headroom under 15%)."""
    if not summary.get("maps"):
        return ["- no maps with every row: nothing to judge"]
    h = summary["headroom"]
    if h < MIN_HEADROOM:
        return [f"- the oracle's headroom over IQL-BFS is {h:.1%}, under {MIN_HEADROOM:.0%}: the issue asks to say so "
                f"and ship the feature; the floors do not apply here"]
    r, share, (fam, worst) = summary["ndr"]["ratio"], summary["share"], summary["worst"]
    verdict = lambda ok: "**PASS**" if ok else "**MISS**"  # noqa: E731
    return [f"- NDR-QL / IQL-BFS (belief) <= {MAX_RATIO:.2f} (geometric mean): {r:.3f} "
            f"({summary['ndr']['low']:.3f} .. {summary['ndr']['high']:.3f}) {verdict(r <= MAX_RATIO)}",
            f"- share of the oracle's gain >= {MIN_SHARE:.0%}: {_pct(share)} {verdict(share >= MIN_SHARE)}",
            f"- no family above {MAX_FAMILY:.2f}x IQL-BFS: worst {fam} {worst:.3f} {verdict(worst <= MAX_FAMILY)}"]


def _sources_line(group: list[dict]) -> str:
    served = Counter(r.get("ndr", {}).get("served") or "fallback" for r in group)
    reasons = Counter(str((r.get("ndr", {}).get("fallback") or {}).get("reasons", ["-"])[0])[:90]
                      for r in group if (r.get("ndr") or {}).get("fallback"))
    weights = sorted({str(r.get("ndr", {}).get("weights_label")) for r in group if r.get("ndr")})
    line = (f"NDR-QL's priors: the model served {served.get('model', 0)} of {len(group)} maps, the fallback (IQL-BFS) "
            f"ran on {served.get('fallback', 0)}; weights {', '.join(weights) or '-'}")
    if reasons:
        line += "; fell back because: " + "; ".join(f"{n}x {why}" for why, n in reasons.most_common(2))
    return line + "\n"


def _iql_ndr_line(s: dict[str, Any]) -> list[str]:
    """IQL-NDR / IQL-BFS (belief) beside NDR-QL (Eq. 5 on the served source's distance; not judged by the floors)."""
    q = s.get("iql_ndr")
    if q is None:
        return []
    o = q["outcomes"]
    return [f"- **IQL-NDR / IQL-BFS (belief)** ({q['maps']} maps): **{q['ratio']:.3f}** ({q['low']:.3f} .. "
            f"{q['high']:.3f}); clear wins / ties / losses {o['wins']} / {o['ties']} / {o['losses']}; share of the "
            f"oracle's gain {_share_text(q['share'], s['headroom'])} (not judged by the floors)"]


def group_text(title: str, group: list[dict], skipped: int, refused: int) -> str:
    """The section of one setting, sensing and grid."""
    s = group_summary(group)
    lines = [f"### {title}: {s['maps']} maps ({skipped} not connected on the ladder, {refused} refused by plan: the "
             f"belief does not connect start and goal)\n"]
    if not s["maps"]:
        return lines[0] + "\n"
    share = np.mean([r["unknown_share"] for r in group])
    o, n = s["oracle"], s["ndr"]
    lines += [f"unknown share of the free space {share:.2f}.\n",
              f"- **headroom** of the oracle over IQL-BFS (belief): **{s['headroom']:.1%}** (95% bootstrap "
              f"{1 - o['high']:.1%} .. {1 - o['low']:.1%}); oracle clearly better / tie / worse on "
              f"{s['oracle_outcomes']['wins']} / {s['oracle_outcomes']['ties']} / {s['oracle_outcomes']['losses']} maps",
              f"- **NDR-QL / IQL-BFS (belief)**: **{n['ratio']:.3f}** ({n['low']:.3f} .. {n['high']:.3f}); clear wins / "
              f"ties / losses {s['ndr_outcomes']['wins']} / {s['ndr_outcomes']['ties']} / {s['ndr_outcomes']['losses']}; "
              f"share of the oracle's gain {_share_text(s['share'], s['headroom'])}; worst family {s['worst'][0]} "
              f"{s['worst'][1]:.3f}",
              *_iql_ndr_line(s), "- " + _sources_line(group)]
    present = [row for row in ROWS if row != REF and any(row in r["rows"] for r in group)]
    lines += ["| family | maps | " + " | ".join(f"{row} / {REF}" for row in present) + f" | {REF} steps |",
              "|---|---:|" + "---:|" * len(present) + "---:|"]
    for fam in [*sorted({r["family"] for r in group}), "all"]:
        sub = [r for r in group if fam in ("all", r["family"]) and REF in r["rows"]]
        cells = []
        for row in present:
            have = [r for r in sub if row in r["rows"]]
            cells.append(f"{_ratio(have, row)['ratio']:.2f}" if have else "-")
        gm = math.exp(np.mean(np.log([_mean(r, REF) for r in sub]))) if sub else math.nan
        lines.append(f"| {'**all**' if fam == 'all' else fam} | {len(sub)} | " + " | ".join(cells) + f" | {gm:,.0f} |")
    quality = []
    for row in (REF, *present):
        vals = [v for r in group if row in r["rows"] for v in r["rows"][row]["ratio"] if v is not None]
        quality.append(f"{row} {np.mean(vals):.3f}" if vals else f"{row} -")
    secs = [r["rows"]["NDR-QL"]["seconds"] for r in group if "NDR-QL" in r["rows"]]
    lines += ["", "path quality (learned path / A* on the true map, mean over runs): " + "; ".join(quality),
              f"seconds of NDR-QL's prediction and priors (median / p95 / max): {_quantiles(secs)}", ""]
    return "\n".join(lines) + "\n"


def report_text(records: list[dict], header: str, grids: tuple[int, ...], settings: list[str],
                senses: tuple[bool, ...]) -> str:
    """The whole report: the floors first, then one section per setting, sensing and grid."""
    rows = joined(records)
    skipped = Counter((r["belief"], r["sense"], r["grid"]) for r in records if r.get("belief") and "skipped" in r)
    refused = Counter((r["belief"], r["sense"], r["grid"]) for r in records if r.get("belief") and "refused" in r)
    parts = [header]
    label, sense = FLOOR_SETTING
    if label in settings and sense in senses:
        parts.append(f"## The floors of issue 54 (blobs 30%, no sensing)\n")
        for grid in (*grids, None):
            group = [r for r in rows if (r["belief"], r["sense"]) == FLOOR_SETTING and grid in (None, r["grid"])]
            if grid is None and len(grids) < 2:
                continue
            s = group_summary(group)
            parts.append(f"{'all grids' if grid is None else f'grid {grid}'} ({s['maps']} maps):\n")
            parts.append("\n".join(floors(s)) + "\n")
    parts.append("## Every setting\n")
    for belief in settings:
        for sense in senses:
            for grid in grids:
                key = (belief, sense, grid)
                group = [r for r in rows if (r["belief"], r["sense"], r["grid"]) == key]
                title = f"{belief}, sensing {'on' if sense else 'off'}, grid {grid}"
                parts.append(group_text(title, group, skipped[key], refused[key]))
    return "\n".join(parts)


__all__ = ["FLOOR_SETTING", "MAX_FAMILY", "MAX_RATIO", "MIN_HEADROOM", "MIN_SHARE", "floors", "group_summary",
           "group_text", "joined", "report_text"]
