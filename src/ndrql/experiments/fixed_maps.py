"""Tables 2 and 3 share one shape: methods on the fixed maps of ``maps_table3.json``, many seeds.

:func:`fixed_map_table` runs (or resumes) every (map, method) task, then writes ``<target>.md``
(maps, mean and median steps beside the paper's single runs, the improvement over QL as the paper
computes it (:func:`stats.relative_improvement`), one detail table per map), ``summary.json`` and
the figures (:mod:`ndrql.viz.reproduce`). :mod:`~ndrql.experiments.table2` and
:mod:`~ndrql.experiments.table3` choose the rows and the paper's reference numbers; a table may add
oracle rows (a method again with the oracle's priors) and the model's share of the oracle's
reduction (:func:`~ndrql.experiments.planning_runs.oracle_share`), per map and pooled.
"""

from __future__ import annotations

import warnings
from dataclasses import asdict
from pathlib import Path
from typing import Any, Callable, Sequence

from ndrql.experiments import stats
from ndrql.experiments.planning_runs import (ORACLE_LABEL, SweepOptions, attach_predictions, oracle_share,
                                             preset_json, run_grid, summarize_runs)
from ndrql.experiments.presets import method_configs
from ndrql.dataset.layout import resolve_root
from ndrql.experiments.problems import MapRef, table3_maps
from ndrql.pipeline.samples import PredictionCache, Problem, load_problems
from ndrql.experiments.report import machine, md_table, pct, planning_header, save_figure, share_section
from ndrql.io import write_json, write_text
from ndrql.planning.methods import Method, build_priors
from ndrql.planning.results import PlanResult
from ndrql.planning.runner import run_plan
from ndrql.viz.reproduce import curves_figure, maps_figure

#: The curves figure shows at most this many methods (the last ones: NDR-QL and its closest rows).
CURVES_COLUMNS = 4


def detail_table(methods: Sequence[str], cells: dict[str, dict], paper_paths: dict[str, str] | None = None) -> str:
    """Per-map table: one row per method with every statistic."""
    header = ["method", "converged", "steps mean", "median", "95% CI", "episodes (mean)", "greedy / A* (mean)",
              "optimal greedy path", "shortest / longest (mean)"]
    if paper_paths:
        header.append("paper shortest / longest")
    rows = []
    for m in methods:
        c = cells[m]
        s = c["steps"]
        row = [m, f"{c['converged']}/{c['runs']}", stats.fmt(s["mean"]), stats.fmt(s["median"]), stats.fmt_ci(s),
               stats.fmt(c["episodes"]["mean"]), stats.fmt(c["ratio"]["mean"], 3), pct(c["optimal_share"]),
               f"{stats.fmt(c['shortest']['mean'])} / {stats.fmt(c['longest']['mean'])}"]
        if paper_paths:
            row.append(paper_paths.get(m, "-"))
        rows.append(row)
    return md_table(header, rows)


def improvement_rows(methods: Sequence[str], maps: Sequence[str], means: dict[tuple[str, str], float | None],
                     paper: dict[str, float] | None = None) -> list[list[str]]:
    """Per method but QL: pooled and per-map improvement over QL on the maps where both converged."""
    rows = []
    for m in methods:
        if m == "QL":
            continue
        pairs = [(means[(k, m)], means[(k, "QL")]) for k in maps]
        ok = [(a, b) for a, b in pairs if a is not None and b is not None]
        if ok:
            pooled = stats.relative_improvement([a for a, _ in ok], [b for _, b in ok])
            per = stats.per_map_improvement([a for a, _ in ok], [b for _, b in ok])
        else:
            pooled = per = None
        row = [m, pct(pooled), pct(per), f"{len(ok)}/{len(maps)}"]
        if paper is not None:
            row.append(pct(paper.get(m)))
        rows.append(row)
    return rows


def _steps_tables(names: Sequence[str], labels: Sequence[str], problems: Sequence[Problem], cells: dict,
                  paper: dict[str, list[int]]) -> list[str]:
    """Mean steps (with the paper's single runs under each row it has) and median steps, maps as columns."""
    header = ["method"] + list(labels)
    rows = []
    for m in names:
        rows.append([f"**{m}**"] + [stats.fmt(cells[(p.key, m)]["steps"]["mean"]) +
                                    ("" if cells[(p.key, m)]["not_converged"] == 0 else f" ({cells[(p.key, m)]['not_converged']} n.c.)")
                                    for p in problems])
        if m in paper:
            rows.append([f"{m} (paper)"] + [stats.fmt(paper[m][i]) for i in range(len(problems))])
    return [md_table(header, rows), "\nMedian convergence steps:\n",
            md_table(header, [[m] + [stats.fmt(cells[(p.key, m)]["steps"]["median"]) for p in problems] for m in names])]


def _improvement_section(names: Sequence[str], problems: Sequence[Problem], cells: dict,
                         paper_improvement: dict[str, float] | None) -> list[str]:
    if "QL" not in names:
        return ["\n## Improvement over the paper's QL row\n", "No QL row here; see table3 for our QL on the same maps and seeds.\n"]
    means = {k: c["steps"]["mean"] for k, c in cells.items()}
    hdr = ["method", "pooled (ours)", "per-map mean (ours)", "maps"] + (["paper"] if paper_improvement else [])
    return ["\n## Improvement over QL\n",
            "Pooled = 1 - sum of per-map mean steps / the same sum for QL (the definition that gives the "
            "paper's 90/80/58% from its own Table 3); per-map = mean of 1 - steps/QL steps.\n",
            md_table(hdr, improvement_rows(names, [p.key for p in problems], means, paper_improvement))]


def replay(p: Problem, m: Method, run: dict, opts: SweepOptions) -> PlanResult:
    """``run`` of method ``m`` on ``p`` again, keeping its final Q-table (the stored run has none)."""
    ql, pc = method_configs(opts, m.name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pri = build_priors(m, p.blocked, p.start, p.goal, p.region, p.guideline, pc)
    return run_plan(p.blocked, p.start, p.goal, m, run["seed"], ql, pc, priors=pri, keep_q=True)


def _figures(problems: Sequence[Problem], labels: Sequence[str], methods: Sequence[Method], results: dict,
             predictions: PredictionCache | None, opts: SweepOptions, out_dir: Path) -> list[Path]:
    """``maps_paths.png`` and one ``curves_<map>.png`` per map (seed ``seed0``)."""
    preds = [predictions.full(p) if predictions is not None else (None, None) for p in problems]
    paths = [{m.name: results[(p.key, m.name)]["runs"][0]["path"] for m in methods} for p in problems]
    figs = [save_figure(maps_figure(problems, labels, preds, paths), out_dir / "maps_paths.png")]
    shown = methods if len(methods) <= CURVES_COLUMNS else methods[-CURVES_COLUMNS:]
    for lab, p in zip(labels, problems):
        first = [results[(p.key, m.name)]["runs"][0] for m in shown]
        fig = curves_figure(p, [m.name for m in shown],
                            [f"{m.name}: {stats.fmt(r['convergence_steps'])} steps" for m, r in zip(shown, first)],
                            first, [replay(p, m, r, opts) for m, r in zip(shown, first)],
                            f"{lab} ({p.split.upper()} {p.index}, {p.category}), seed {opts.seed0}")
        figs.append(save_figure(fig, out_dir / f"curves_{lab}.png"))
    return figs


def _share_section(labels: Sequence[str], problems: Sequence[Problem], results: dict, row: str,
                   seeds: int) -> tuple[list[str], dict[str, dict]]:
    """Markdown of the share of the oracle's reduction, per map and pooled, and the numbers."""
    shares = {lab: oracle_share(results, [p.key], row) for lab, p in zip(labels, problems)}
    shares["**pooled**"] = oracle_share(results, [p.key for p in problems], row)
    return share_section(shares, row, row + ORACLE_LABEL, seeds, "map"), {k.strip("*"): v for k, v in shares.items()}


def fixed_map_table(target: str, methods: Sequence[Method], n_maps: int, opts: SweepOptions, out_dir: str | Path,
                    paper: dict[str, list[int]], paper_paths: dict[str, list[str]] | None = None,
                    paper_improvement: dict[str, float] | None = None, log: Callable[[str], None] = print,
                    oracle_rows: Sequence[Method] = ()) -> Path:
    """Table 2 or 3: ``methods`` on the first ``n_maps`` fixed maps; writes ``<out>/<target>.md``,
    ``summary.json`` and figures; returns the markdown path. ``oracle_rows``: methods run again with the
    oracle's priors (rows ``<name> (oracle priors)``), each with its share of the oracle's reduction."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    info = machine()
    root = resolve_root(opts.data)
    all_refs = table3_maps()[:n_maps]
    problems, skipped = load_problems(root, [(r.split, r.index) for r in all_refs])
    if skipped:
        log(f"skipped (disconnected): {skipped}")
    refs: list[MapRef] = [r for r in all_refs if any(p.key == r.key for p in problems)]
    labels = [r.label for r in refs]
    problems, predictions = attach_predictions(problems, methods, out_dir.parent, opts)
    results, rep = run_grid(problems, methods, opts, out_dir, predictions, desc=target, oracle_rows=oracle_rows)
    names = [m.name for m in methods]
    rows = names + [m.name + ORACLE_LABEL for m in oracle_rows]
    cells = {(p.key, m): summarize_runs(results[(p.key, m)]["runs"]) for p in problems for m in rows}
    md = [planning_header(f"{target}: convergence steps of Q-learning methods on fixed test maps", opts, info, predictions,
                          names=names)]
    md.append("Maps (`src/ndrql/experiments/maps_table3.json`):\n")
    md.append(md_table(["map", "sample", "category", "A* moves (50x50)", "NDR-QI thd", "why"],
                       [[lab, f"{p.split} {p.index}", p.category, p.astar,
                         stats.fmt(results[(p.key, names[-1])]["threshold"], 2), r.reason]
                        for lab, p, r in zip(labels, problems, refs)],
                       ["l", "l", "l", "r", "r", "l"]))
    md.append(f"\n## Convergence steps, mean over {opts.seeds} seeds (converged runs; paper: one run)\n")
    md += _steps_tables(rows, labels, problems, cells, paper)
    md += _improvement_section(rows, problems, cells, paper_improvement)
    shares = {}
    for m in oracle_rows:
        section, shares[m.name] = _share_section(labels, problems, results, m.name, opts.seeds)
        md += section
    md.append("\n## Per map\n")
    for i, (lab, p) in enumerate(zip(labels, problems)):
        pp = {m: paper_paths[m][i] for m in paper_paths} if paper_paths else None
        md.append(f"\n### {lab}: {p.split} {p.index} ({p.category}), A* = {p.astar} moves\n")
        md.append(detail_table(rows, {m: cells[(p.key, m)] for m in rows}, pp))
    md.append("\nColumns: *converged* = runs whose greedy path was stable for W = 20 episodes within "
              f"{opts.ql.max_episodes} episodes; steps statistics over converged runs (Student-t 95% CI of the mean); "
              "*greedy / A\\** = converged greedy path length over the A* optimum on the same 50x50 grid; "
              "*shortest / longest* = fewest / most moves of the training episodes that reached the goal "
              "up to convergence (the paper's 'shortest / longest distance'), averaged over seeds.\n")
    figs = _figures(problems, labels, methods, results, predictions, opts, out_dir)
    md.append("\n## Figures\n")
    md += [f"![{f.stem}]({f.name})" for f in figs]
    path = write_text(out_dir / f"{target}.md", "\n".join(md) + "\n")
    summary: dict[str, Any] = {
        "target": target, "machine": info,
        "options": {"seeds": opts.seed_list, "ql": asdict(opts.ql), "priors": asdict(opts.priors), "preset": preset_json(opts)},
        "weights": predictions.describe() if predictions else None, "prior_from": opts.prior_from, "skipped": skipped,
        "maps": [{"label": lab, "key": p.key, "category": p.category, "astar": p.astar} for lab, p in zip(labels, problems)],
        "cells": {f"{k[0]}|{k[1]}": v for k, v in cells.items()}}
    if shares:
        summary["oracle_share"] = shares
    write_json(out_dir / "summary.json", summary, indent=1, strict=False)
    log(f"{target}: {len(rep.computed)} tasks computed, {len(rep.reused)} reused, {rep.seconds:.0f} s")
    return path
