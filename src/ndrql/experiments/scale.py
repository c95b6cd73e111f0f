"""The ``scale`` study: Table 3's comparison (plus A*) on hundreds of test samples.

``per_category`` samples from each category of TEST/SEEN and TEST/UNSEEN (:func:`scale_refs`), every
method with every seed; per group (all, each split, each split and category) the success rate, the
convergence steps, the improvement over QL as the paper computes it (pooled over maps) and the
optimality gap (converged greedy path / A* - 1). Samples whose start and goal do not connect on the
planning grid are skipped and listed. The planning grid is the paper's (area-averaged) grid of 50
cells, or of ``grid`` cells. With the model's priors, NDR-QL also runs with the oracle's (row
``NDR-QL (oracle priors)``) and each group gets the model's share of the oracle's reduction
(:func:`~ndrql.experiments.planning_runs.oracle_share`); with ``opts.prior_from == "oracle"`` the
NDR-QL row itself has the oracle's priors.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np
from tqdm import tqdm

from ndrql.errors import NoPathError
from ndrql.experiments import stats
from ndrql.experiments.planning_runs import (ORACLE_LABEL, SweepOptions, attach_predictions, oracle_share,
                                             preset_json, run_grid, summarize_runs)
from ndrql.dataset.layout import resolve_root
from ndrql.pipeline.samples import Problem, load_problem
from ndrql.experiments.report import machine, md_table, pct, planning_header, save_figure, share_section
from ndrql.experiments.table3 import TABLE3_METHODS
from ndrql.io import write_json, write_text
from ndrql.maps.grid import PLANNING_SIZE
from ndrql.planning.methods import get_method
from ndrql.viz.reproduce import scale_distributions, scale_figure


def scale_refs(per_category: int) -> list[tuple[str, int]]:
    """``per_category`` samples from each of the 4 categories of SEEN and of UNSEEN, evenly spaced
    through each block of 300 (indices ``block * 300 + k * (300 // per_category)``)."""
    if not 1 <= per_category <= 300:
        raise ValueError(f"per_category must be in 1..300, got {per_category}")
    step = 300 // per_category
    return [(split, b * 300 + k * step) for split in ("seen", "unseen") for b in range(4) for k in range(per_category)]


def groups_of(problems: list[Problem]) -> dict[str, list[Problem]]:
    """``all``, each split, and each ``split/category`` (in the order the samples come)."""
    groups: dict[str, list[Problem]] = {"all": problems}
    for split in ("seen", "unseen"):
        groups[split] = [p for p in problems if p.split == split]
        for cat in dict.fromkeys(p.category for p in problems if p.split == split):
            groups[f"{split}/{cat}"] = [p for p in problems if p.split == split and p.category == cat]
    return groups


def aggregate(ps: Sequence[Problem], names: Sequence[str], results: dict) -> dict[str, Any]:
    """One group's numbers per method: success, steps, per-map mean steps, gap, improvement over QL."""
    gm: dict[str, Any] = {}
    for m in names:
        runs = [r for p in ps for r in results[(p.key, m)]["runs"]]
        conv = [r for r in runs if r["converged"]]
        per_map_mean = [summarize_runs(results[(p.key, m)]["runs"])["steps"]["mean"] for p in ps]
        gaps = [r["length_ratio"] - 1.0 for r in conv]
        gm[m] = {
            "maps": len(ps), "runs": len(runs), "converged": len(conv),
            "success_rate": len(conv) / len(runs) if runs else None,
            "steps": stats.describe([r["convergence_steps"] for r in conv]),
            "per_map_mean_steps": per_map_mean,
            "gap": stats.describe(gaps),
            "gap_p90": float(np.percentile(gaps, 90)) if gaps else None,
            "optimal_share": float(np.mean([g < 1e-12 for g in gaps])) if gaps else None,
            "wall_time": stats.describe([r["wall_time"] for r in runs]),
        }
    for m in names:
        if m != "QL":
            pairs = [(a, b) for a, b in zip(gm[m]["per_map_mean_steps"], gm["QL"]["per_map_mean_steps"])
                     if a is not None and b is not None]
            gm[m]["improvement_pooled"] = stats.relative_improvement(*zip(*pairs)) if pairs else None
            gm[m]["improvement_per_map"] = stats.per_map_improvement(*zip(*pairs)) if pairs else None
    return gm


def results_table(agg: dict[str, dict], names: Sequence[str], groups: dict[str, list[Problem]]) -> str:
    """One row per group and method, and A* (optimal by construction) per group."""
    header = ["group", "method", "maps", "success (converged runs)", "steps mean", "median", "95% CI",
              "improvement over QL (pooled / per-map)", "greedy/A* - 1: mean", "p90", "optimal paths"]
    rows = []
    for gname, gm in agg.items():
        for m in names:
            a = gm[m]
            imp = "-" if m == "QL" else f"{pct(a['improvement_pooled'])} / {pct(a['improvement_per_map'])}"
            rows.append([gname, m, a["maps"], f"{pct(a['success_rate'])} ({a['converged']}/{a['runs']})",
                         stats.fmt(a["steps"]["mean"]), stats.fmt(a["steps"]["median"]), stats.fmt_ci(a["steps"]), imp,
                         stats.fmt(a["gap"]["mean"], 3), stats.fmt(a["gap_p90"], 3), pct(a["optimal_share"])])
        rows.append([gname, "A*", len(groups[gname]), "100%", "-", "-", "-", "-", "0", "0", "100%"])
    return md_table(header, rows, ["l", "l"] + ["r"] * (len(header) - 2))


def scale(opts: SweepOptions, out_dir: str | Path, per_category: int = 50, log: Callable[[str], None] = print,
          grid: int = PLANNING_SIZE) -> Path:
    """Table 3's comparison (plus A*) on ``8 * per_category`` test samples: success, steps, optimality gap;
    on the planning grid of ``grid`` cells."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    info = machine()
    root = resolve_root(opts.data)
    refs = scale_refs(per_category)
    problems, skipped = [], []
    for split, index in tqdm(refs, desc="load samples", unit="map", disable=not opts.progress):
        try:
            problems.append(load_problem(root, split, index, size=grid))
        except NoPathError as exc:
            skipped.append({"split": split, "index": index, "reason": str(exc)})
    methods = [get_method(m) for m in TABLE3_METHODS]
    problems, predictions = attach_predictions(problems, methods, out_dir.parent, opts, grid)
    oracle_rows = [get_method("NDR-QL")] if opts.prior_from == "model" else []
    results, rep = run_grid(problems, methods, opts, out_dir, predictions, desc="scale", records=False,
                            oracle_rows=oracle_rows)
    names = [m.name for m in methods]
    rows = names + [m.name + ORACLE_LABEL for m in oracle_rows]
    groups = groups_of(problems)
    md = [planning_header(f"scale: {', '.join(names)} and A* on {len(refs)} test samples", opts, info, predictions,
                          f"Samples: {per_category} per category, evenly spaced in each block of 300 "
                          f"(`scale_refs({per_category})`); {len(skipped)} skipped as disconnected on the planning grid "
                          f"({', '.join(s['split'] + ' ' + str(s['index']) for s in skipped) or 'none'})."
                          + ("" if grid == PLANNING_SIZE else f" Planning grid: {grid}x{grid} cells (the paper's rule)."),
                          names)]
    agg = {gname: aggregate(ps, rows, results) for gname, ps in groups.items() if ps}
    md.append("\n## Results\n")
    md.append(results_table(agg, rows, groups))
    md.append("\nSuccess = runs that converged (docs/method.md) within the episode budget; steps over converged runs "
              "(pooled over maps and seeds, Student-t 95% CI); optimality gap = converged greedy path / A* - 1 "
              f"on the same {grid}x{grid} grid (A* is optimal by construction: gap 0 on every connected sample).\n")
    shares = {m.name: {g: oracle_share(results, [p.key for p in ps], m.name) for g, ps in groups.items() if ps}
              for m in oracle_rows}
    for m, sh in shares.items():
        md += share_section(sh, m, m + ORACLE_LABEL, opts.seeds)
    converged = {m: [r for p in problems for r in results[(p.key, m)]["runs"] if r["converged"]] for m in rows}
    figs = [save_figure(scale_figure(agg, rows), out_dir / "scale.png"),
            save_figure(scale_distributions(converged), out_dir / "scale_distributions.png")]
    md.append("\n## Figures\n")
    md += [f"![{f.stem}]({f.name})" for f in figs]
    path = write_text(out_dir / "scale.md", "\n".join(md) + "\n")
    write_json(out_dir / "summary.json", {"machine": info, "skipped": skipped, "groups": agg, "preset": preset_json(opts),
                                          "weights": predictions.describe() if predictions else None, "grid": grid,
                                          "prior_from": opts.prior_from, **({"oracle_share": shares} if shares else {})},
               indent=1, strict=False)
    log(f"scale: {len(rep.computed)} tasks computed, {len(rep.reused)} reused, {rep.seconds:.0f} s")
    return path
