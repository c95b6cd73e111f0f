"""The floors part of the transfer and release reports (issue 53) and the time of each stage.

For every planning grid the report judges each floor as *met* or *missed*, with its number (:func:`floors`):

- no family where NDR-QL, as ``ndrql plan`` runs it (:func:`~ndrql.experiments.transfer_report.plan_row`), needs
  more than :data:`MAX_FAMILY_VS_BFS` times IQL-BFS's steps (geometric mean over the family's maps);
- plan's prediction stage and priors at most :data:`MAX_PRIOR_SECONDS` on every map;
- NDR-QL's in-process work (prediction, priors, learning) at most :data:`MAX_WORK_RATIO` times IQL-BFS's, median
  over maps (:func:`work_seconds`).

Every grid gets the wall seconds per stage (:func:`stages_table`: median, 95th percentile and maximum): the model's
forward, plan's exact source, the A* and the BFS distance field on the grid, and each row's run (mean over seeds).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ndrql.experiments.report import md_table
from ndrql.experiments.transfer_report import BFS_ROW, MODEL, ORACLE, ROWS, plan_row, summarize

#: The floors apply from this grid size (cells) up (issue 53: every grid).
FLOOR_GRID = 0
#: Largest NDR-QL (as plan runs it) / IQL-BFS geometric mean in any family (issue 53: "never above IQL-BFS's by
#: more than 2%").
MAX_FAMILY_VS_BFS = 1.02
#: Largest seconds of plan's prediction stage and priors on any map (issue 53: load + prediction + priors <= 2 s).
MAX_PRIOR_SECONDS = 2.0
#: Largest median ratio of NDR-QL's in-process work (prediction, priors, learning) to IQL-BFS's.
MAX_WORK_RATIO = 3.0
#: The stages timed per case, besides each row's run.
STAGES = ("prediction", "exact", "astar", "bfs")


@dataclass(frozen=True)
class Floor:
    """One floor of the release report judged on one grid."""

    name: str
    """What is measured, with its limit."""
    value: str
    """The measured number, as shown."""
    met: bool
    """Whether the floor holds."""

    def line(self) -> str:
        """``- <name>: <value>: met`` (or ``missed``)."""
        return f"- {self.name}: {self.value}: {'met' if self.met else 'missed'}"


def family_ratios(records: list[dict], seed: int = 0) -> dict[str, float]:
    """Per family with a planned map: NDR-QL / IQL in the geometric mean with plan's fallback."""
    out = {}
    for fam in sorted({r["family"] for r in records if not r["skipped"]}):
        s = summarize([r for r in records if r["family"] == fam], seed)
        out[fam] = s["plan_vs_iql"]["ratio"]
    return out


def capped_runs(records: list[dict], row: str = MODEL) -> int:
    """Runs of ``row`` that hit their cap (did not converge) over the planned cases of ``records``."""
    return int(sum(not c for r in records if not r["skipped"] for c in r["runs"][row]["converged"]))


def stage_tail(records: list[dict], stage: str) -> str:
    """``median / 95th percentile / max`` wall seconds of one stage over the planned cases ("-" when untimed)."""
    vals = [r["seconds"][stage] for r in records if not r["skipped"] and stage in r.get("seconds", {})]
    if not vals:
        return "-"
    return f"{np.median(vals):.3f} / {np.percentile(vals, 95):.3f} / {max(vals):.3f}"


def stage_medians(records: list[dict]) -> dict[str, float]:
    """Median wall seconds over the planned cases of each stage (:data:`STAGES`) and each row's run (mean over
    seeds per case); a stage no case recorded is left out (records written before stages were timed)."""
    ok = [r for r in records if not r["skipped"]]
    out: dict[str, float] = {}
    for stage in STAGES:
        vals = [r["seconds"][stage] for r in ok if stage in r.get("seconds", {})]
        if vals:
            out[stage] = float(np.median(vals))
    for row in ROWS:
        vals = [r["runs"][row]["seconds"] for r in ok if "seconds" in r["runs"].get(row, {})]
        if vals:
            out[row] = float(np.median(vals))
    return out


def family_vs_bfs(records: list[dict], seed: int = 0) -> dict[str, float]:
    """Per family, NDR-QL as plan runs it against IQL-BFS (geometric mean over maps)."""
    out = {}
    for fam in sorted({r["family"] for r in records if not r["skipped"]}):
        s = summarize([r for r in records if r["family"] == fam], seed)
        if "plan_vs_bfs" in s:
            out[fam] = s["plan_vs_bfs"]["ratio"]
    return out


def work_seconds(record: dict) -> tuple[float, float] | None:
    """``(NDR-QL's, IQL-BFS's)`` in-process work on one case: plan's prediction stage (the exact source, or the
    model's forward where plan would ask it) plus the row's priors and learning (mean over seeds); ``None`` for
    records without them."""
    sec, runs = record.get("seconds", {}), record["runs"]
    row = plan_row(record)
    if "exact" not in sec or BFS_ROW not in runs or "seconds" not in runs.get(row, {}):
        return None
    stage = sec["exact"] if row == ORACLE else 0.0
    return stage + runs[row]["seconds"], runs[BFS_ROW]["seconds"]


def floors(records: list[dict], n: int, seed: int = 0) -> list[Floor]:
    """Issue 53's floors on the cases of grid ``n`` (module docstring); ``[]`` without a planned map."""
    s = summarize(records, seed)
    if not s["maps"] or "plan_vs_bfs" not in s:
        return []
    fams = family_vs_bfs(records, seed)
    above = [f"{f} {x:.3f}" for f, x in fams.items() if x > MAX_FAMILY_VS_BFS]
    worst = max(fams, key=fams.get)
    out = [Floor(f"no family where NDR-QL (as plan runs it) needs more than {MAX_FAMILY_VS_BFS:.2f}x IQL-BFS's steps "
                 f"(geometric mean)", ", ".join(above) if above else f"highest {worst} {fams[worst]:.3f}", not above)]
    ok = [r for r in records if not r["skipped"]]
    stage = [r["seconds"].get("exact", 0.0) for r in ok if "seconds" in r]
    if stage:
        out.append(Floor(f"prediction and priors at most {MAX_PRIOR_SECONDS:g} s on every map",
                         f"median {np.median(stage):.3f} s, 95th percentile {np.percentile(stage, 95):.3f} s, "
                         f"max {max(stage):.3f} s", max(stage) <= MAX_PRIOR_SECONDS))
    pairs = [w for r in ok if (w := work_seconds(r)) is not None]
    if pairs:
        ratio = float(np.median([a / b for a, b in pairs if b > 0]))
        out.append(Floor(f"NDR-QL's in-process work at most {MAX_WORK_RATIO:g}x IQL-BFS's (median over maps)",
                         f"{ratio:.2f}x", ratio <= MAX_WORK_RATIO))
    return out


def stages_table(records: list[dict], grids: tuple[int, ...]) -> str:
    """Markdown: per grid, the median / 95th percentile / maximum wall seconds of each stage and the median of each
    row's run."""
    meds = {n: stage_medians([r for r in records if r["n"] == n]) for n in grids}
    cols = [c for c in ROWS if any(c in m for m in meds.values())]
    names = {"prediction": "model forward (--prior-from model)", "exact": "exact source (plan)", "astar": "A*",
             "bfs": "BFS distance field"}
    rows = [[str(n)] + [stage_tail([r for r in records if r["n"] == n], st) for st in STAGES]
            + [f"{m[c]:.3f}" if c in m else "-" for c in cols] for n, m in meds.items()]
    return md_table(["grid"] + [f"{names[st]}: median / p95 / max" for st in STAGES] + [f"run: {c}" for c in cols], rows)


def render_large(records: list[dict], grids: tuple[int, ...], seed: int = 0) -> str:
    """Markdown: the seconds per stage and grid, then for each grid the floors block of issue 53 (each floor met or
    missed, with its number)."""
    parts = ["\n**Time per stage** (wall seconds over the planned maps of each grid, measured on the machine that ran "
             "the report; a row's run is its mean over seeds of priors and training):\n\n" + stages_table(records, grids)]
    for n in grids:
        if n < FLOOR_GRID:
            continue
        fl = floors([r for r in records if r["n"] == n], n, seed)
        if not fl:
            parts.append(f"**Floors at grid {n}**: no map planned with an IQL-BFS row, nothing judged.")
            continue
        met = sum(f.met for f in fl)
        parts.append(f"**Floors at grid {n}** (issue 53: NDR-QL against the exact distance, and its time): "
                     f"{met} of {len(fl)} met.\n\n" + "\n".join(f.line() for f in fl))
    return "\n\n".join(parts) + "\n"
