"""The large-grid part of the transfer and release reports: the floors of docs/large-maps.md and the time
of each stage.

For a planning grid of at least :data:`FLOOR_GRID` cells the report judges each floor of "Floors for the
next model" (docs/large-maps.md) as *met* or *missed*, with its number (:func:`floors`):

- NDR-QL's steps over IQL's, the geometric mean over maps of per-map ratios with ``plan``'s fallback (a map
  whose prediction is uninformative counts at IQL's steps), at most :data:`MAX_STEP_RATIO`; missed too when a
  run of the model's row hit its cap (a run that did not converge is no success, whatever steps it used);
- the share of maps whose prediction is uninformative at most :data:`MAX_UNINFORMATIVE`;
- no family where NDR-QL (with the fallback) is slower than IQL in the geometric mean;
- the model's share of the oracle's gain over IQL, ``(1 - G(NDR/IQL)) / (1 - G(oracle/IQL))`` with G the
  geometric mean over all maps of the grid, at least :data:`MIN_ORACLE_SHARE`;
- at :data:`PREDICTION_GRID` cells, the median seconds of the prediction at most :data:`MAX_PREDICTION_SECONDS`.

Every grid gets the median wall seconds per stage (:func:`stage_medians`): the prediction (forward pass
and drawing on the grid), the A* and the BFS distance field on the grid, each row's run (mean over seeds).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ndrql.experiments.report import md_table
from ndrql.experiments.transfer_report import MODEL, ORACLE, ROWS, summarize

#: The floors apply from this grid size (cells) up.
FLOOR_GRID = 128
#: Largest NDR-QL / IQL geometric mean of per-map step ratios (with plan's fallback).
MAX_STEP_RATIO = 0.6
#: Largest share of maps whose prediction is uninformative.
MAX_UNINFORMATIVE = 0.10
#: Smallest share of the oracle's gain over IQL (geometric means).
MIN_ORACLE_SHARE = 0.75
#: The grid (cells) at which the prediction's time is judged, and its largest median seconds.
PREDICTION_GRID, MAX_PREDICTION_SECONDS = 256, 0.5
#: The stages timed per case, besides each row's run.
STAGES = ("prediction", "astar", "bfs")


@dataclass(frozen=True)
class Floor:
    """One floor of docs/large-maps.md judged on one grid."""

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


def floors(records: list[dict], n: int, seed: int = 0) -> list[Floor]:
    """The floors of docs/large-maps.md on the cases of grid ``n`` (module docstring); ``[]`` without a planned map."""
    s = summarize(records, seed)
    if not s["maps"]:
        return []
    plan = s["plan_vs_iql"]["ratio"]
    capped = capped_runs(records)
    raw = s["rows"][MODEL]["vs_iql"]["ratio"]
    value = f"{plan:.2f} ({raw:.2f} without the fallback)" + (f"; {capped} runs hit their cap" if capped else "")
    out = [Floor(f"NDR-QL / IQL steps, geometric mean with plan's fallback, at most {MAX_STEP_RATIO}", value,
                 plan <= MAX_STEP_RATIO and not capped),
           Floor(f"prediction uninformative on at most {100 * MAX_UNINFORMATIVE:.0f}% of maps",
                 f"{100 * s['uninformative']:.0f}% of {s['maps']}", s["uninformative"] <= MAX_UNINFORMATIVE)]
    slower = [f"{f} {x:.2f}" for f, x in family_ratios(records, seed).items() if x > 1]
    out.append(Floor("no family where NDR-QL (with the fallback) is slower than IQL in the geometric mean",
                     "slower: " + ", ".join(slower) if slower else "none slower", not slower))
    if ORACLE in s["rows"]:
        share = s["share_geo"]
        shown = "undefined (the oracle is not faster than IQL)" if np.isnan(share) else f"{100 * share:.0f}%"
        out.append(Floor(f"share of the oracle's gain over IQL in geometric means at least {100 * MIN_ORACLE_SHARE:.0f}%",
                         shown, bool(share >= MIN_ORACLE_SHARE)))
    if n == PREDICTION_GRID:
        t = stage_medians(records).get("prediction")
        out.append(Floor(f"prediction at {n} cells at most {MAX_PREDICTION_SECONDS} s (median)",
                         "not timed" if t is None else f"{t:.2f} s", t is not None and t <= MAX_PREDICTION_SECONDS))
    return out


def stages_table(records: list[dict], grids: tuple[int, ...]) -> str:
    """Markdown: per grid, the median wall seconds of each stage and each row's run."""
    meds = {n: stage_medians([r for r in records if r["n"] == n]) for n in grids}
    cols = [c for c in (*STAGES, *ROWS) if any(c in m for m in meds.values())]
    names = {"prediction": "prediction (forward + drawing)", "astar": "A*", "bfs": "BFS distance field"}
    rows = [[str(n)] + [f"{m[c]:.3f}" if c in m else "-" for c in cols] for n, m in meds.items()]
    return md_table(["grid"] + [names.get(c, f"run: {c}") for c in cols], rows)


def second_opinion_line(records: list[dict]) -> str | None:
    """How often the base model was asked for a second opinion where the companion's region was uninformative,
    and how often it served (``plan``'s rule, :func:`~ndrql.pipeline.predictions.predict_on_grid`), and the relays
    where both were (:mod:`ndrql.pipeline.relay`); ``None`` when it never was asked."""
    planned = [r for r in records if not r["skipped"]]
    asked = [r["second_opinion"] for r in planned if r.get("second_opinion")]
    if not asked:
        return None
    line = (f"- second opinion (the base model through its own view, asked where the companion's region was "
            f"uninformative): asked on {len(asked)} of {len(planned)} maps, served on {sum(a['served'] for a in asked)}")
    relayed = [a["relay"] for a in asked if (a.get("relay") or {}).get("hops") or "back" in (a.get("relay") or {})]
    if relayed:
        back = [r for r in relayed if "back" in r]
        line += (f"; where both were uninformative the companion was relayed (asked again from where its region "
                 f"ended) on {len(relayed)} maps, {sum(len(r['hops']) + len(r.get('back', [])) for r in relayed)} hops "
                 f"in all" + (f" (on {len(back)} also from the goal's side)" if back else "")
                 + f", and its joined regions served on {sum(_one(r) for r in relayed)}")
    turned = [a["relay"]["turned"] for a in asked if "turned" in (a.get("relay") or {})]
    if turned:
        line += (f"; where that failed too the companion averaged over {turned[0]['orientations']} orientations was "
                 f"asked on {len(turned)} maps (relayed on {sum(bool(t['hops']) or 'back' in t for t in turned)}) "
                 f"and served on {sum(t['served'] for t in turned)}")
    heads = [a["propagated"] for a in asked if a.get("propagated")]
    if heads:
        line += (f"; where everything failed the propagating head was asked on {len(heads)} maps and served on "
                 f"{sum(h['served'] for h in heads)}")
    return line


def _one(relayed: dict) -> bool:
    """Whether the relay of one orientation served (not counting the turn that may follow it)."""
    return bool(relayed["served"]) and not (relayed.get("turned") or {}).get("served")


def render_large(records: list[dict], grids: tuple[int, ...], seed: int = 0) -> str:
    """Markdown: the median seconds per stage and grid, then for each grid of at least :data:`FLOOR_GRID` cells
    the floors block (each floor met or missed, with its number)."""
    parts = ["\n**Time per stage** (median wall seconds over the planned maps of each grid, measured on the machine "
             "that ran the report; a row's run is its mean over seeds, priors and training):\n\n"
             + stages_table(records, grids)]
    for n in grids:
        if n < FLOOR_GRID:
            continue
        fl = floors([r for r in records if r["n"] == n], n, seed)
        if not fl:
            parts.append(f"**Floors at grid {n}** (docs/large-maps.md): no map planned, nothing judged.")
            continue
        met = sum(f.met for f in fl)
        second = second_opinion_line([r for r in records if r["n"] == n])
        parts.append(f"**Floors at grid {n}** (docs/large-maps.md, 'Floors for the next model'): {met} of {len(fl)} met.\n\n"
                     + "\n".join(f.line() for f in fl)
                     + "\n- figures at grids 50 and 100 and on the paper's data no worse: not judged by this report "
                       "(compare with docs/results.md)" + (f"\n{second}" if second else ""))
    return "\n\n".join(parts) + "\n"
