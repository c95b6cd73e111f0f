"""The figures and tables of the transfer report (and of the release report, which runs the same code).

A record is one (map, grid) case of :func:`ndrql.experiments.transfer.collect`: per row the steps of
each seed (converged or not: the steps used), whether it converged and its greedy path / A*. The
report leads with the geometric mean over maps of the per-map step ratio against IQL and against the
paper's QL, each with a seeded bootstrap interval over maps; then clear wins, ties and clear losses
against IQL by a test over seeds (:func:`ndrql.experiments.stats.compare_seeds`); pooled sums only
beside the same ratio without the largest map; every row's steps beside its path length (mean, 95th
percentile and worst over runs); per family, the maps that connect on no grid tried.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ndrql.experiments.ceiling import larger_sizes
from ndrql.experiments.report import md_table
from ndrql.experiments.stats import TIE, geomean_ratio, outcomes, pooled_ratio, share_of_oracle
from ndrql.pipeline.predictions import MIN_THRESHOLD

#: The rows of the report, in order. ``QL``: the paper's constants; ``QL (tuned)``: searched constants
#: (:data:`ndrql.experiments.transfer.TUNED_QL`); ``IQL (BFS distance)``: IQL's constants with Eq. 5 on the
#: exact 4-connected BFS distance to the goal instead of the straight line; ``NDR-QL (oracle)``: NDR-QL's
#: constants with priors drawn from an 8-connected shortest path of the planning grid (the labels' rule).
#: The last two use no learning: references for what a perfect distance or a perfect prediction gives.
ROWS = ("QL", "QL (tuned)", "IQL", "IQL (BFS distance)", "NDR-QL (model)", "NDR-QL (oracle)")
MODEL = "NDR-QL (model)"


def judged_threshold(record: dict) -> float | None:
    """The Eq. 7 threshold by which ``ndrql plan`` judges the prediction: the highest of the paper's
    schedule (0.99 in steps of 0.01) at which the region joins start and goal, whatever threshold
    schedule the preset's NDR-QL runs use (records written before it was stored: the run's own)."""
    if "judged_threshold" in record:
        return record["judged_threshold"]
    return record["runs"][MODEL]["threshold"]


def plan_steps(record: dict, cut: float = MIN_THRESHOLD) -> list[int]:
    """The steps ``ndrql plan`` would spend on this case for NDR-QL: the model row's where the judged
    Eq. 7 threshold (:func:`judged_threshold`) is at least ``cut`` (plan's
    :data:`~ndrql.pipeline.predictions.MIN_THRESHOLD`), else IQL's (plan's default fallback for an
    uninformative prediction; its other test, the guideline's mass on obstacles, is not applied here)."""
    thd = judged_threshold(record)
    row = MODEL if thd is not None and thd >= cut else "IQL"
    return record["runs"][row]["steps"]


def against_iql(ndr: Sequence[float], iql: Sequence[float], tie: float = TIE) -> tuple[int, int, int]:
    """Maps won (fewer mean steps than IQL), tied (within ``tie`` relative, either side) and lost by more,
    from per-map mean steps, without a test over seeds (the probes' count; the report's clear wins,
    ties and losses are :func:`ndrql.experiments.stats.outcomes`)."""
    gap = np.asarray(ndr, float) / np.asarray(iql, float) - 1
    return int((gap < 0).sum()), int((np.abs(gap) <= tie).sum()), int((gap > tie).sum())


def _means(records: list[dict], row: str) -> list[float]:
    return [float(np.mean(r["runs"][row]["steps"])) for r in records]


def _paths(records: list[dict], row: str) -> dict[str, float]:
    """Greedy path / A* over the converged runs: mean, 95th percentile, worst; and the runs that did not converge."""
    x = np.asarray([v for r in records for v in r["runs"][row]["ratio"] if v is not None], float)
    bad = int(sum(not c for r in records for c in r["runs"][row]["converged"]))
    if not x.size:
        return {"mean": float("nan"), "p95": float("nan"), "worst": float("nan"), "not_converged": bad}
    return {"mean": float(x.mean()), "p95": float(np.percentile(x, 95)), "worst": float(x.max()), "not_converged": bad}


def summarize(records: list[dict], seed: int = 0) -> dict:
    """Every figure of a group of case records (same seeds in every row); bootstrap intervals from ``seed``."""
    ok = [r for r in records if not r["skipped"]]
    out: dict = {"maps": len(ok), "skipped": len(records) - len(ok)}
    if not ok:
        return out
    rows = [row for row in ROWS if all(row in r["runs"] for r in ok)]
    iql, ql = _means(ok, "IQL"), _means(ok, "QL")
    out["grown"] = int(sum(r.get("size", r["n"]) != r["n"] for r in ok))
    out["region_f1"] = 100 * float(np.nanmean([r["f1"][0] for r in ok]))
    out["guideline_f1"] = 100 * float(np.nanmean([r["f1"][1] for r in ok]))
    out["rows"] = {}
    for row in rows:
        m = _means(ok, row)
        steps = [r["runs"][row]["steps"] for r in ok]
        out["rows"][row] = {
            "geomean_steps": float(np.exp(np.mean(np.log(m)))),
            "vs_iql": geomean_ratio(m, iql, seed), "vs_ql": geomean_ratio(m, ql, seed),
            "pooled_vs_iql": pooled_ratio(m, iql, seed),
            "against_iql": outcomes(steps, [r["runs"]["IQL"]["steps"] for r in ok]),
            "path": _paths(ok, row)}
    plan = [float(np.mean(plan_steps(r))) for r in ok]
    out["plan_vs_iql"] = geomean_ratio(plan, iql, seed)
    out["plan_worse_than_iql"] = float(np.mean([p > i for p, i in zip(plan, iql)]))
    thd = [judged_threshold(r) for r in ok]
    out["threshold_below_half"] = float(np.mean([t is None or t < 0.5 for t in thd]))
    if "NDR-QL (oracle)" in rows:
        out["share"] = share_of_oracle(*([sum(r["runs"][row]["steps"]) for r in ok] for row in (MODEL, "NDR-QL (oracle)", "QL")))
    return out


def _ratio(d: dict, ci: bool = True) -> str:
    """A ratio as a change in percent, with its interval: ``-45% (-52..-38)``."""
    if d.get("maps", 1) == 0 or np.isnan(d["ratio"]):
        return "-"
    core = f"{100 * (d['ratio'] - 1):+.0f}%"
    return core + (f" ({100 * (d['low'] - 1):+.0f}..{100 * (d['high'] - 1):+.0f})" if ci else "")


def _wtl(o: dict) -> str:
    lo, hi = o["win_ci"]
    return f"{o['wins']} / {o['ties']} / {o['losses']} ({100 * o['win_share']:.0f}%, {100 * lo:.0f}-{100 * hi:.0f})"


def _pooled(p: dict) -> str:
    rest = p["without_largest"]
    return f"{_ratio(p)}; " + ("-" if np.isnan(rest) else f"{100 * (rest - 1):+.0f}% without the largest")


def headline_table(s: dict) -> str:
    """One row per method: typical steps, against IQL and the paper's QL, clear wins/ties/losses against IQL,
    pooled with and without the largest map, path length."""
    head = ["method", "steps (geomean)", "vs IQL: geomean ratio (95% CI)", "vs QL (paper)", "clear wins / ties / losses vs IQL",
            "pooled vs IQL (95% CI); without the largest map", "path / A*: mean, p95, worst", "not converged"]
    rows = []
    for row, d in s["rows"].items():
        p = d["path"]
        same = row == "IQL"
        rows.append([row, f"{d['geomean_steps']:,.0f}", "-" if same else _ratio(d["vs_iql"]), _ratio(d["vs_ql"]),
                     "-" if same else _wtl(d["against_iql"]), "-" if same else _pooled(d["pooled_vs_iql"]),
                     f"{p['mean']:.3f}, {p['p95']:.3f}, {p['worst']:.3f}", str(p["not_converged"])])
    return md_table(head, rows)


def family_table(records: list[dict], seed: int = 0) -> str:
    """NDR-QL (model) against IQL per family: maps planned and not connected, geomean ratio, clear outcomes,
    pooled with and without the largest map, the worst path, F1 and the oracle's share."""
    head = ["family", "maps (on a finer grid)", "not connected", "NDR-QL vs IQL: geomean (95% CI)",
            "clear wins / ties / losses", "pooled vs IQL; without the largest", "worst path / A*", "region F1",
            "share of oracle"]
    rows = []
    for fam in sorted({r["family"] for r in records}) + ["all"]:
        s = summarize([r for r in records if fam == "all" or r["family"] == fam], seed)
        name = f"**{fam}**" if fam == "all" else fam
        if not s["maps"]:
            rows.append([name, "0", str(s["skipped"])] + ["-"] * (len(head) - 3))
            continue
        d = s["rows"][MODEL]
        rows.append([name, f"{s['maps']} ({s['grown']})", str(s["skipped"]), _ratio(d["vs_iql"]), _wtl(d["against_iql"]),
                     _pooled(d["pooled_vs_iql"]), f"{d['path']['worst']:.3f}", f"{s['region_f1']:.1f}",
                     f"{100 * s['share']:.0f}%" if "share" in s else "-"])
    return md_table(head, rows)


def render_tables(records: list[dict], grids: tuple[int, ...], seed: int = 0) -> str:
    """Markdown: per grid, the headline table (every method) and the per-family table (NDR-QL against IQL)."""
    parts = []
    for n in grids:
        at_n = [r for r in records if r["n"] == n]
        s = summarize(at_n, seed)
        finer = ", ".join(map(str, larger_sizes(n))) or "no finer size"
        if not s["maps"]:
            parts.append(f"**Planning grid {n}**: no map connects ({s['skipped']} skipped)")
            continue
        plan = s["plan_vs_iql"]
        parts.append(
            f"**Planning grid {n}** (safe grid; maps that need it on {finer}): {s['maps']} maps planned, "
            f"{s['skipped']} connect on no size tried.\n\n" + headline_table(s) +
            f"\n\nWhat `ndrql plan` spends (the model's run, or IQL's where the prediction does not connect start and goal "
            f"at Eq. 7 threshold {MIN_THRESHOLD}): {_ratio(plan)} against IQL in geometric mean; more than IQL on "
            f"{100 * s['plan_worse_than_iql']:.0f}% of the maps.\n\n" + family_table(at_n, seed))
    parts.append(
        "*geomean ratio*: the geometric mean over maps of a method's mean steps over the seeds divided by IQL's (or the "
        "paper's QL's) on the same map, as a change; in brackets the 95% percentile bootstrap interval over maps (seeded). "
        f"*clear wins / ties / losses*: a map is a clear win or loss when the mean steps differ by more than {100 * TIE:.1f}% "
        "and Welch's t-test on the log steps of the seeds rejects equal means at 5%; in brackets the share of clear wins "
        "and its 95% Wilson interval. *pooled*: summed steps over maps (dominated by the largest maps), with its "
        "bootstrap interval and the ratio without the map with the most steps. *path / A\\**: greedy path of the learned "
        "policy over the 4-connected optimum of the planning grid, over converged runs. *share of oracle*: "
        "(1 - NDR-QL/QL) / (1 - oracle/QL) on pooled steps.")
    return "\n\n".join(parts) + "\n"
