"""The figures and tables of the transfer report (and of the release report, which runs the same code).

A record is one (map, grid) case of :func:`ndrql.experiments.transfer.collect`: per row the steps of
each seed (converged or not: the steps used), whether it converged and its greedy path / A*. The
report leads with the geometric mean over maps of the per-map step ratio against IQL and against the
paper's QL, each with a seeded bootstrap interval over maps; then clear wins, ties and clear losses
against IQL by a test over seeds (:func:`ndrql.experiments.stats.compare_seeds`); pooled sums only
beside the same ratio without the largest map; every row's steps beside its path length (mean, 95th
percentile and worst over runs); per family, the maps that connect on no grid tried. Beside them: the
geometric mean with ``plan``'s fallback (an uninformative prediction counts at IQL's steps), the share of
uninformative predictions and the oracle's share of the gain over IQL from geometric means. A run that
hit its cap (did not converge) counts with the steps it used and wins no map (:func:`capped_outcomes`).
The rows run per grid: :func:`default_rows` (no QL rows above :data:`QL_ROW_LIMIT` cells) or ``--rows``.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ndrql.experiments.ceiling import larger_sizes
from ndrql.experiments.report import md_table
from ndrql.errors import NdrqlError
from ndrql.experiments.stats import (TIE, compare_seeds, geomean_ratio, pooled_ratio, share_of_oracle,
                                     share_of_oracle_geomean, tally)
from ndrql.pipeline.fallback import (LARGE_GRID, LARGE_MIN_THRESHOLD, MAX_REGION_COVER, max_region_cover, min_threshold,
                                    region_reason)

#: The rows of the report, in order. ``QL``: the paper's constants; ``QL (tuned)``: searched constants
#: (:data:`ndrql.experiments.transfer.TUNED_QL`); ``IQL (BFS distance)``: IQL's constants with Eq. 5 on the
#: exact 4-connected BFS distance to the goal instead of the straight line; ``NDR-QL (oracle)``: NDR-QL's
#: constants with priors drawn from an 8-connected shortest path of the planning grid (the labels' rule).
#: The last two use no learning: references for what a perfect distance or a perfect prediction gives.
ROWS = ("QL", "QL (tuned)", "IQL", "IQL (BFS distance)", "NDR-QL (model)", "NDR-QL (oracle)")
#: The exact-distance reference every report leads with.
BFS_ROW = "IQL (BFS distance)"
MODEL = "NDR-QL (model)"
ORACLE = "NDR-QL (oracle)"
#: The rows without a prior (tabular QL from a zero Q-table): about 10^7 steps per run on 256 cells (with the
#: paper's constants a run on a ``large-dev-256`` map hit the 20,000-episode cap after 2.2x10^7 steps: a lower
#: bound, not a figure).
QL_ROWS = ("QL", "QL (tuned)")
#: Grids of more cells run without :data:`QL_ROWS` unless ``--rows`` asks for them.
QL_ROW_LIMIT = 100
#: Rows every run needs: the baseline of every ratio and the model.
REQUIRED_ROWS = ("IQL", MODEL)


def default_rows(n: int) -> tuple[str, ...]:
    """The rows run on a planning grid of ``n`` cells: every row up to :data:`QL_ROW_LIMIT` cells, above it
    every row but :data:`QL_ROWS` (they would take hours, :func:`not_run_note`)."""
    return ROWS if n <= QL_ROW_LIMIT else tuple(r for r in ROWS if r not in QL_ROWS)


def parse_rows(text: str | None) -> tuple[str, ...] | None:
    """``--rows``: ``None`` (or empty) for :func:`default_rows`, ``all`` for every row, else row names separated
    by commas (in :data:`ROWS`' order; :data:`REQUIRED_ROWS` must be among them)."""
    if text is None or not text.strip():
        return None
    if text.strip() == "all":
        return ROWS
    names = [t.strip() for t in text.split(",") if t.strip()]
    bad = [t for t in names if t not in ROWS]
    if bad:
        raise NdrqlError(f"--rows: unknown row {bad[0]!r}; rows: {', '.join(ROWS)} (or all)")
    missing = [r for r in REQUIRED_ROWS if r not in names]
    if missing:
        raise NdrqlError(f"--rows must include {' and '.join(REQUIRED_ROWS)} (every ratio needs them), not {missing[0]!r}")
    return tuple(r for r in ROWS if r in names)


def rows_at(n: int, chosen: tuple[str, ...] | None) -> tuple[str, ...]:
    """The rows run at grid ``n``: ``chosen`` (``--rows``) or :func:`default_rows`."""
    return chosen if chosen is not None else default_rows(n)


def not_run_note(n: int, rows: tuple[str, ...]) -> str:
    """One sentence on the rows of :data:`ROWS` not run at grid ``n`` and why ('' when every row ran)."""
    left = [r for r in ROWS if r not in rows]
    if not left:
        return ""
    why = f"QL rows not run above {QL_ROW_LIMIT} cells: ~10^7 steps per run" \
        if set(left) == set(QL_ROWS) and n > QL_ROW_LIMIT else "left out by --rows"
    return f"Rows not run at grid {n}: {', '.join(left)} ({why})."


def judged_threshold(record: dict) -> float | None:
    """The Eq. 7 threshold by which ``ndrql plan`` judges the prediction: the highest of the paper's
    schedule (0.99 in steps of 0.01) at which the region joins start and goal, whatever threshold
    schedule the preset's NDR-QL runs use (records written before it was stored: the run's own)."""
    if "judged_threshold" in record:
        return record["judged_threshold"]
    return record["runs"][MODEL]["threshold"]


def record_size(record: dict) -> int:
    """Cells per side of the grid the case was planned on (the size asked for in records without ``size``)."""
    return int(record.get("size", record.get("n", 0)))


def record_cut(record: dict) -> float:
    """Plan's cut for the case's planning grid (:func:`~ndrql.pipeline.fallback.min_threshold` of the size it
    was planned on)."""
    return min_threshold(record_size(record))


def uninformative(record: dict, cut: float | None = None) -> bool:
    """Whether ``ndrql plan`` calls the prediction uninformative: no Eq. 7 threshold of at least ``cut`` (plan's,
    :func:`record_cut`, when not given) joins start and goal (:func:`judged_threshold`), or, on a grid where
    plan limits it (:func:`~ndrql.pipeline.fallback.max_region_cover`), the region covers more of the free
    cells than that at the judged threshold (records written before ``region_cover`` was stored: not tested)."""
    return region_reason(judged_threshold(record), record.get("region_cover"), record_size(record), cut) is not None


def plan_row(record: dict, cut: float | None = None) -> str:
    """The row whose runs are what ``ndrql plan`` spends on this case for NDR-QL.

    Records with the judge's verdicts (``verdicts``, :func:`ndrql.pipeline.judge.judge` in
    :func:`~ndrql.experiments.transfer.collect`): plan's default policy on a known map is the exact source, whose
    priors are the ``NDR-QL (oracle)`` row's (:func:`ndrql.pipeline.sources.drawn_priors`); where the judge rejects
    it, plan runs IQL-BFS (its fallback). Older records: the model row where the prediction is informative at
    ``cut``, else IQL (the fallback of those days)."""
    v = record.get("verdicts")
    if v is not None:
        if v["exact"]["accepted"]:
            return ORACLE
        return BFS_ROW if BFS_ROW in record["runs"] else "IQL"
    return "IQL" if uninformative(record, cut) else MODEL


def model_row(record: dict) -> str:
    """The row ``plan --prior-from model`` spends: the model's where the judge accepts its prediction, else IQL-BFS
    (IQL where that row did not run)."""
    v = record.get("verdicts")
    ok = v["model"]["accepted"] if v is not None else not uninformative(record)
    return MODEL if ok else (BFS_ROW if BFS_ROW in record["runs"] else "IQL")


def plan_steps(record: dict, cut: float | None = None) -> list[int]:
    """The steps ``ndrql plan`` would spend on this case for NDR-QL (:func:`plan_row`)."""
    return record["runs"][plan_row(record, cut)]["steps"]


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


def capped_outcomes(records: list[dict], row: str) -> dict:
    """Clear wins, ties and clear losses of ``row`` against IQL by a test over seeds
    (:func:`~ndrql.experiments.stats.compare_seeds`), where a run that hit its cap (did not converge) wins
    nothing: a map where ``row`` did not converge on some seed is a loss when IQL converged on every seed,
    at best a tie when IQL did not either (its steps are only a lower bound of what it would need)."""
    res = []
    for r in records:
        a, b = r["runs"][row], r["runs"]["IQL"]
        out = compare_seeds(a["steps"], b["steps"])
        if not all(a["converged"]):
            out = 1 if all(b["converged"]) else max(out, 0)
        res.append(out)
    return tally(res)


def summarize(records: list[dict], seed: int = 0) -> dict:
    """Every figure of a group of case records (same seeds in every row); bootstrap intervals from ``seed``."""
    ok = [r for r in records if not r["skipped"]]
    out: dict = {"maps": len(ok), "skipped": len(records) - len(ok)}
    if not ok:
        return out
    rows = [row for row in ROWS if all(row in r["runs"] for r in ok)]
    iql = _means(ok, "IQL")
    ql = _means(ok, "QL") if "QL" in rows else None
    out["grown"] = int(sum(r.get("size", r["n"]) != r["n"] for r in ok))
    out["region_f1"] = 100 * float(np.nanmean([r["f1"][0] for r in ok]))
    out["guideline_f1"] = 100 * float(np.nanmean([r["f1"][1] for r in ok]))
    out["rows"] = {}
    for row in rows:
        m = _means(ok, row)
        out["rows"][row] = {
            "geomean_steps": float(np.exp(np.mean(np.log(m)))),
            "vs_iql": geomean_ratio(m, iql, seed), "vs_ql": geomean_ratio(m, ql, seed) if ql else None,
            "pooled_vs_iql": pooled_ratio(m, iql, seed),
            "against_iql": capped_outcomes(ok, row),
            "path": _paths(ok, row)}
    plan = [float(np.mean(plan_steps(r))) for r in ok]
    out["plan_vs_iql"] = geomean_ratio(plan, iql, seed)
    if BFS_ROW in rows:
        bfs = _means(ok, BFS_ROW)
        out["plan_vs_bfs"] = geomean_ratio(plan, bfs, seed)
        out["plan_against_bfs"] = tally([compare_seeds(plan_steps(r), r["runs"][BFS_ROW]["steps"]) for r in ok])
        model = [float(np.mean(r["runs"][model_row(r)]["steps"])) for r in ok]
        out["model_vs_bfs"] = geomean_ratio(model, bfs, seed)
        out["model_against_bfs"] = tally([compare_seeds(r["runs"][model_row(r)]["steps"], r["runs"][BFS_ROW]["steps"])
                                          for r in ok])
        out["exact_rejected"] = float(np.mean([plan_row(r) != ORACLE for r in ok]))
    out["plan_worse_than_iql"] = float(np.mean([p > i for p, i in zip(plan, iql)]))
    thd = [judged_threshold(r) for r in ok]
    out["threshold_below_half"] = float(np.mean([t is None or t < 0.5 for t in thd]))
    out["uninformative"] = float(np.mean([uninformative(r) for r in ok]))
    if ORACLE in rows:
        oracle = out["rows"][ORACLE]["vs_iql"]["ratio"]
        out["share_geo"] = share_of_oracle_geomean(out["plan_vs_iql"]["ratio"], oracle)  # with plan's fallback
        out["share_geo_raw"] = share_of_oracle_geomean(out["rows"][MODEL]["vs_iql"]["ratio"], oracle)
        if ql:
            out["share"] = share_of_oracle(*([sum(r["runs"][row]["steps"]) for r in ok] for row in (MODEL, ORACLE, "QL")))
    return out


def _ratio(d: dict | None, ci: bool = True) -> str:
    """A ratio as a change in percent, with its interval: ``-45% (-52..-38)``."""
    if d is None or d.get("maps", 1) == 0 or np.isnan(d["ratio"]):
        return "-"
    core = f"{100 * (d['ratio'] - 1):+.0f}%"
    return core + (f" ({100 * (d['low'] - 1):+.0f}..{100 * (d['high'] - 1):+.0f})" if ci else "")


def _pct(x: float | None) -> str:
    """A share in percent, ``-`` when missing or undefined."""
    return "-" if x is None or np.isnan(x) else f"{100 * x:.0f}%"


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


def lead_table(records: list[dict], seed: int = 0) -> str:
    """What the model adds: per family, NDR-QL as ``plan`` runs it and as ``--prior-from model`` runs it, each
    against IQL-BFS (the exact distance, no model) with its interval and clear wins / ties / losses; then NDR-QL
    against IQL and the paper's QL."""
    head = ["family", "maps", "plan / IQL-BFS (95% CI)", "clear wins / ties / losses vs IQL-BFS",
            "--prior-from model / IQL-BFS", "model: wins / ties / losses vs IQL-BFS", "plan / IQL", "plan / QL"]
    rows = []
    for fam in sorted({r["family"] for r in records}) + ["all"]:
        s = summarize([r for r in records if fam == "all" or r["family"] == fam], seed)
        name = f"**{fam}**" if fam == "all" else fam
        if not s["maps"] or "plan_vs_bfs" not in s:
            continue
        ql = "-"
        if "QL" in s["rows"]:
            ql = _ratio(geomean_ratio([float(np.mean(plan_steps(r))) for r in records if not r["skipped"] and
                                       (fam == "all" or r["family"] == fam)],
                                      _means([r for r in records if not r["skipped"] and (fam == "all" or r["family"] == fam)],
                                             "QL"), seed))
        rows.append([name, str(s["maps"]), _ratio(s["plan_vs_bfs"]), _wtl(s["plan_against_bfs"]),
                     _ratio(s["model_vs_bfs"]), _wtl(s["model_against_bfs"]), _ratio(s["plan_vs_iql"]), ql])
    return md_table(head, rows)


def family_table(records: list[dict], seed: int = 0) -> str:
    """NDR-QL (model) against IQL per family: maps planned and not connected, geomean ratio, clear outcomes,
    pooled with and without the largest map, the worst path, F1, the oracle's share on pooled steps against
    QL; then the geomean ratio with plan's fallback, the share of uninformative predictions and the oracle's
    share of the gain over IQL in geometric means (with the fallback)."""
    head = ["family", "maps (on a finer grid)", "not connected", "NDR-QL vs IQL: geomean (95% CI)",
            "clear wins / ties / losses", "pooled vs IQL; without the largest", "worst path / A*", "region F1",
            "share of oracle (pooled, vs QL)", "with plan's fallback vs IQL: geomean", "uninformative",
            "share of oracle's gain over IQL (geomean)"]
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
                     _pct(s.get("share")), _ratio(s["plan_vs_iql"]), _pct(s["uninformative"]), _pct(s.get("share_geo"))])
    return md_table(head, rows)


def _cover_note(records: list[dict]) -> str:
    """``, or covers more than X% of the free cells there`` when some planned case of ``records`` lies on a grid
    where plan limits the region's cover (:func:`~ndrql.pipeline.fallback.max_region_cover`)."""
    limits = {max_region_cover(record_size(r)) for r in records if not r["skipped"]} - {None}
    return f", or covers more than {max(limits):.0%} of the free cells there" if limits else ""


def _cuts(records: list[dict]) -> str:
    """Plan's cut(s) over the planned cases of ``records`` (a grid whose maps grew past 128 cells has two)."""
    cuts = sorted({record_cut(r) for r in records if not r["skipped"]})
    return " / ".join(map(str, cuts)) or str(min_threshold(0))


def rows_run(records: list[dict]) -> tuple[str, ...]:
    """The rows of :data:`ROWS` that ran on every planned case of ``records``."""
    ok = [r for r in records if not r["skipped"]]
    return tuple(row for row in ROWS if ok and all(row in r["runs"] for r in ok))


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
        lead = ""
        if "plan_vs_bfs" in s:
            lead = (f"**What the model adds.** NDR-QL as `ndrql plan` runs it (on a map it knows: the exact source, "
                    f"IQL-BFS where the judge rejects it, on {_pct(s['exact_rejected'])} of the maps): "
                    f"{_ratio(s['plan_vs_bfs'])} steps against IQL-BFS in geometric mean (clear wins / ties / losses "
                    f"{_wtl(s['plan_against_bfs'])}); with the network's priors (`--prior-from model`, IQL-BFS where the "
                    f"judge rejects them) {_ratio(s['model_vs_bfs'])} ({_wtl(s['model_against_bfs'])}).\n\n"
                    + lead_table(at_n, seed) + "\n\n")
        parts.append(
            f"**Planning grid {n}** (safe grid; maps that need it on {finer}): {s['maps']} maps planned, "
            f"{s['skipped']} connect on no size tried.\n\n" + lead + headline_table(s) +
            f"\n\nWhat `ndrql plan` spends (the model's run, or IQL's where the prediction does not connect start and goal "
            f"at Eq. 7 threshold {_cuts(at_n)}{_cover_note(at_n)}): {_ratio(plan)} against IQL in geometric mean; more than IQL on "
            f"{100 * s['plan_worse_than_iql']:.0f}% of the maps; the prediction is uninformative on "
            f"{_pct(s['uninformative'])} of the maps; share of the oracle's gain over IQL in geometric means "
            f"{_pct(s.get('share_geo'))} with plan's fallback ({_pct(s.get('share_geo_raw'))} without)."
            + (f" {note}" if (note := not_run_note(n, rows_run(at_n))) else "") + "\n\n" + family_table(at_n, seed))
    parts.append(
        "*geomean ratio*: the geometric mean over maps of a method's mean steps over the seeds divided by IQL's (or the "
        "paper's QL's) on the same map, as a change; in brackets the 95% percentile bootstrap interval over maps (seeded). "
        f"*clear wins / ties / losses*: a map is a clear win or loss when the mean steps differ by more than {100 * TIE:.1f}% "
        "and Welch's t-test on the log steps of the seeds rejects equal means at 5%; in brackets the share of clear wins "
        "and its 95% Wilson interval. *pooled*: summed steps over maps (dominated by the largest maps), with its "
        "bootstrap interval and the ratio without the map with the most steps. *path / A\\**: greedy path of the learned "
        "policy over the 4-connected optimum of the planning grid, over converged runs. *share of oracle (pooled, vs QL)*: "
        "(1 - NDR-QL/QL) / (1 - oracle/QL) on pooled steps (only where the QL row ran). *with plan's fallback*: a map whose "
        "prediction is uninformative (no Eq. 7 threshold of at least plan's cut joins start and goal: 0 up to "
        f"{LARGE_GRID} cells, {LARGE_MIN_THRESHOLD} above; above {LARGE_GRID} cells also a region over more than "
        f"{MAX_REGION_COVER:.0%} of the free cells at that threshold) counts at IQL's steps. "
        "*share of oracle's gain over IQL (geomean)*: (1 - G(NDR-QL/IQL)) / (1 - G(oracle/IQL)), G the geometric mean "
        "over maps, NDR-QL with plan's fallback. *not converged*: runs that hit their cap (max_episodes episodes of at "
        "most max_steps moves, recorded per row in summary.json); they count with the steps they used and win no map.")
    return "\n\n".join(parts) + "\n"
