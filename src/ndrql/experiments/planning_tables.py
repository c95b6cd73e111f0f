"""Tables 2 and 3 of the paper and the ``scale`` study: Q-learning methods on dataset maps, many seeds.

Every (map, method) pair is one sweep task running all seeds (:mod:`ndrql.experiments.sweep`), so
a killed run resumes where it stopped and any executor gives the same table. Per method and map
the tables report mean, median and 95% CI of convergence steps over the converged runs, the number
that did not converge, the greedy path against A*, and the paper-style shortest/longest training
path; the improvement over QL is computed as the paper does (:func:`stats.relative_improvement`).
"""

from __future__ import annotations

import hashlib
import warnings
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ndrql.experiments import stats
from ndrql.experiments.paper import paper_table
from ndrql.experiments.presets import method_configs, preset_line
from ndrql.experiments.problems import PredictionCache, Problem, load_problem, load_problems, resolve_root, table3_maps
from ndrql.experiments.report import machine, machine_line, md_table, save_figure
from ndrql.experiments.sweep import Task, fingerprint, run_sweep
from ndrql.io import write_json, write_text
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import Method, build_priors, get_method

#: Bump when a change in this module changes task results (forces recomputation of stored tasks).
TASK_VERSION = 1


def method_fields(m: Method) -> dict[str, Any]:
    """What of a method determines its runs (its name and priors; the description does not), for fingerprints."""
    return {"name": m.name, "d_crf": m.d_crf, "n_crf": m.n_crf, "d_qi": m.d_qi, "n_qi": m.n_qi,
            "qi_mask_only": m.qi_mask_only}


TABLE3_METHODS = ("QL", "O-QL", "IQL", "NDR-QL")
#: Table 2's rows in the paper's order. ``N-Q`` alone is Eq. 6's mask term only; ``D-Q + N-Q`` is
#: Eq. 6 as a whole, which is what the registry's ``N-Q`` method runs (it contains the D-QI term).
TABLE2_ROWS = (
    Method("D-C", d_crf=True),
    Method("N-C", n_crf=True),
    Method("D-C+N-C", d_crf=True, n_crf=True),
    Method("D-Q", d_qi=True),
    Method("N-Q", n_qi=True, qi_mask_only=True),
    Method("D-Q+N-Q", d_qi=True, n_qi=True),
    Method("NDR-QL", d_crf=True, n_crf=True, d_qi=True, n_qi=True),
)

@dataclass(frozen=True)
class SweepOptions:
    """How a planning table is run (the CLI fills this)."""

    seeds: int = 10
    """Runs per (map, method): seeds ``seed0 .. seed0 + seeds - 1``."""
    seed0: int = 0
    """First seed."""
    workers: int = 2
    """Parallel workers (the machine is shared: keep <= 2)."""
    executor: str = "process"
    """``process``, ``serial`` or ``ray``."""
    ray_address: str | None = None
    """Existing Ray cluster (``None``: start a local instance)."""
    progress: bool = True
    """tqdm progress bars with ETA on stderr."""
    ql: QLConfig = field(default_factory=QLConfig)
    priors: PriorConfig = field(default_factory=PriorConfig)
    data: str | None = None
    """Dataset root (default: :func:`ndrql.dataset.layout.default_root`, ``$NDRQL_DATASET`` first)."""
    weights: str | None = None
    """NDR weights (default: ``$NDRQL_WEIGHTS`` or the shipped ones)."""
    command: str = ""
    """The command line, recorded in the report."""
    preset: Any = None
    """A :class:`~ndrql.planning.preset.Preset` giving each row its constants (``None``: ``ql`` and ``priors``)."""

    @property
    def seed_list(self) -> list[int]:
        return list(range(self.seed0, self.seed0 + self.seeds))


# --------------------------------------------------------------------------------------- tasks


def plan_task(blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int], method: Method,
              seeds: list[int], ql: QLConfig, pc: PriorConfig, region: np.ndarray | None,
              guideline: np.ndarray | None, records_seed: int | None = None) -> dict[str, Any]:
    """All seeds of one method on one planning grid -> JSON-able dict (the sweep's unit of work)."""
    from ndrql.planning.runner import plan

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pri = build_priors(method, blocked, start, goal, region, guideline, pc)
    runs = []
    for s in seeds:
        r = plan(blocked, start, goal, method, s, ql, pc, priors=pri, keep_records=(s == records_seed))
        runs.append(r.to_dict(include_records=(s == records_seed)))
    return {"variant": method.name, "threshold": pri.threshold, "warnings": [str(w.message) for w in caught],
            "runs": runs}


def _preset_json(opts: SweepOptions) -> dict | None:
    from ndrql.planning.preset import preset_to_dict

    return None if opts.preset is None else preset_to_dict(opts.preset)


def _array_digest(a: np.ndarray | None) -> str | None:
    if a is None:
        return None
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:16]


def make_tasks(problems: Sequence[Problem], variants: Sequence[Method], opts: SweepOptions,
               weights_digest: str | None, records: bool = True) -> list[Task]:
    tasks = []
    for p in problems:
        for v in variants:
            region = p.region if v.needs_ndr else None
            guideline = p.guideline if v.needs_ndr else None
            if v.needs_ndr and (region is None or guideline is None):
                raise ValueError(f"{p.key}: variant {v.name} needs predictions; attach them first")
            rec = opts.seed0 if records else None
            ql, pc = method_configs(opts, v.name)
            fp = fingerprint(TASK_VERSION, p.key, _array_digest(p.blocked), p.start, p.goal, method_fields(v),
                             opts.seed_list, asdict(ql), asdict(pc), weights_digest if v.needs_ndr else None, rec)
            key = f"{p.key}__{v.name}".replace(" ", "_")
            tasks.append(Task(key, plan_task, (p.blocked, p.start, p.goal, v, opts.seed_list, ql,
                                               pc, region, guideline, rec), fp))
    return tasks


def run_grid(problems: Sequence[Problem], variants: Sequence[Method], opts: SweepOptions, out_dir: Path,
             weights_digest: str | None, desc: str, records: bool = True) -> tuple[dict[tuple[str, str], dict], Any]:
    """Run (or resume) every (problem, variant) task; results by ``(problem key, variant name)``
    and the sweep's :class:`~ndrql.experiments.sweep.SweepReport`."""
    from ndrql.planning import kernel

    kernel.warm_up()  # compile/load once before forking workers
    tasks = make_tasks(problems, variants, opts, weights_digest, records)
    rep = run_sweep(tasks, out_dir / "tasks", executor=opts.executor, workers=opts.workers,
                    progress=opts.progress, desc=desc, ray_address=opts.ray_address)
    out = {}
    it = iter(rep.results.values())
    for p in problems:
        for v in variants:
            out[(p.key, v.name)] = next(it)
    return out, rep


# --------------------------------------------------------------------------------- statistics


def summarize_runs(runs: list[dict]) -> dict[str, Any]:
    """Statistics of one (map, method) cell over its seeds (docs/method.md)."""
    conv = [r for r in runs if r["converged"]]
    n = len(runs)
    ratio = [r["length_ratio"] for r in conv]
    return {
        "runs": n,
        "converged": len(conv),
        "not_converged": n - len(conv),
        "steps": stats.describe([r["convergence_steps"] for r in runs]),
        "episodes": stats.describe([r["convergence_episode"] for r in runs]),
        "path_length": stats.describe([r["path_length"] for r in conv]),
        "ratio": stats.describe(ratio),
        "optimal_share": (sum(1 for x in ratio if x is not None and abs(x - 1.0) < 1e-12) / len(conv)) if conv else None,
        "shortest": stats.describe([r["shortest_success_length"] for r in conv]),
        "longest": stats.describe([r["longest_success_length"] for r in conv]),
        "first_success": stats.describe([r["first_success_episode"] for r in runs]),
        "wall_time": stats.describe([r["wall_time"] for r in runs]),
    }


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.0f}%"


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
               stats.fmt(c["episodes"]["mean"]), stats.fmt(c["ratio"]["mean"], 3), _pct(c["optimal_share"]),
               f"{stats.fmt(c['shortest']['mean'])} / {stats.fmt(c['longest']['mean'])}"]
        if paper_paths:
            row.append(paper_paths.get(m, "-"))
        rows.append(row)
    return md_table(header, rows)


def improvement_rows(methods: Sequence[str], maps: Sequence[str], means: dict[tuple[str, str], float | None],
                     paper: dict[str, float] | None = None) -> list[list[str]]:
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
        row = [m, _pct(pooled), _pct(per), f"{len(ok)}/{len(maps)}"]
        if paper is not None:
            row.append(_pct(paper.get(m)))
        rows.append(row)
    return rows


# ------------------------------------------------------------------------------------ figures


def _curves_figure(p: Problem, label: str, variants: Sequence[Method], results: dict, opts: SweepOptions) -> Any:
    """Paper Fig. 6 style: per method, steps and return per episode (dashed line at convergence),
    and the Q-table after convergence with the greedy path (seed ``seed0``, re-run to get Q)."""
    from ndrql.planning.runner import plan
    from ndrql.viz.curves import plot_training_curves
    from ndrql.viz.maps import new_figure, plot_endpoints
    from ndrql.viz.overlays import METHOD_COLORS
    from ndrql.viz.qtable import plot_qtable

    n = len(variants)
    fig = new_figure(figsize=(3.2 * n, 9.0))
    fig.set_layout_engine("constrained")
    axes = fig.subplots(3, n, squeeze=False)
    for j, v in enumerate(variants):
        res = results[(p.key, v.name)]
        run0 = res["runs"][0]
        color = METHOD_COLORS.get(v.name)
        if "records" in run0:
            plot_training_curves(axes[0, j], axes[1, j], run0["records"], convergence_episode=run0["convergence_episode"],
                                 color=color)
        axes[0, j].set_title(f"{v.name}: {stats.fmt(run0['convergence_steps'])} steps", fontsize=9)
        ql, pc = method_configs(opts, v.name)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            pri = build_priors(v, p.blocked, p.start, p.goal, p.region, p.guideline, pc)
        r = plan(p.blocked, p.start, p.goal, v, run0["seed"], ql, pc, priors=pri, keep_q=True)
        ax = axes[2, j]
        plot_qtable(ax, r.q_table, p.blocked.shape, blocked=p.blocked)
        if r.path:
            pts = np.asarray(r.path, float)
            ax.plot(pts[:, 1], pts[:, 0], "-", color="white", linewidth=1.4)
        plot_endpoints(ax, p.start, p.goal, size=30)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(f"Q-table, path {r.path_length} (A* {p.astar})", fontsize=8)
    fig.suptitle(f"{label} ({p.split.upper()} {p.index}, {p.category}), seed {opts.seed0}", fontsize=10)
    return fig


def _maps_figure(problems: Sequence[Problem], labels: Sequence[str], variants: Sequence[Method], results: dict,
                 predictions: PredictionCache | None) -> Any:
    """Row 1: region (green) and guideline (red) predictions on each map; row 2: every method's
    greedy path (seed ``seed0``) on the same planning grid."""
    from ndrql.viz.maps import new_figure
    from ndrql.viz.overlays import plot_method_paths, plot_prediction

    n = len(problems)
    fig = new_figure(figsize=(2.6 * n, 6.2))
    fig.set_layout_engine("constrained")
    axes = fig.subplots(2, n, squeeze=False)
    for j, (p, label) in enumerate(zip(problems, labels)):
        if predictions is not None:
            region, guide = predictions.full(p)
            plot_prediction(axes[0, j], p.obstacles, region, guide, p.source_start, p.source_goal)
        else:
            plot_prediction(axes[0, j], p.obstacles, None, None, p.source_start, p.source_goal)
        axes[0, j].set_title(f"{label}\n{p.split} {p.index} {p.category}", fontsize=8)
        paths = {v.name: results[(p.key, v.name)]["runs"][0]["path"] for v in variants}
        plot_method_paths(axes[1, j], p.blocked, paths, p.start, p.goal)
    return fig


# ------------------------------------------------------------------------------------- tables


def _header(title: str, opts: SweepOptions, info: dict, predictions: PredictionCache | None, extra: str = "",
            variants: Sequence[Method] = ()) -> str:
    lines = [f"# {title}", "", f"Command: `{opts.command}`" if opts.command else "", "",
             f"Machine: {machine_line(info)}.", "",
             f"Seeds {opts.seed0}..{opts.seed0 + opts.seeds - 1} per map and method; QLConfig {asdict(opts.ql)}; "
             f"PriorConfig {asdict(opts.priors)}."]
    if predictions is not None:
        lines += ["", f"NDR weights: `{predictions.weights}` (sha256 {predictions.digest})."]
    if opts.preset is not None:
        lines[6] = f"Seeds {opts.seed0}..{opts.seed0 + opts.seeds - 1} per map and method."
        lines += ["", preset_line(opts, [v.name for v in variants])]
    if extra:
        lines += ["", extra]
    return "\n".join(lines) + "\n"


def _attach(problems: list[Problem], variants: Sequence[Method], out_root: Path, opts: SweepOptions,
            predictions: PredictionCache | None = None) -> tuple[list[Problem], PredictionCache | None]:
    if not any(v.needs_ndr for v in variants):
        return problems, predictions
    if predictions is None:
        predictions = PredictionCache(out_root / "predictions", opts.weights)
    from tqdm import tqdm

    out = [predictions.attach(p) for p in tqdm(problems, desc="NDR predictions", unit="map", disable=not opts.progress)]
    return out, predictions


def fixed_map_table(target: str, variants: Sequence[Method], n_maps: int, opts: SweepOptions, out_dir: str | Path,
                    paper: dict[str, list[int]], paper_paths: dict[str, list[str]] | None = None,
                    paper_improvement: dict[str, float] | None = None, log: Callable[[str], None] = print) -> Path:
    """Table 2 or 3: ``variants`` on the first ``n_maps`` fixed maps; writes ``<out>/<target>.md``,
    ``summary.json`` and figures; returns the markdown path."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    info = machine()
    root = resolve_root(opts.data)
    refs = table3_maps()[:n_maps]
    problems, skipped = load_problems(root, [(r.split, r.index) for r in refs])
    if skipped:
        log(f"skipped (disconnected): {skipped}")
    labels = [r.label for r in refs if any(p.key == r.key for p in problems)]
    problems, predictions = _attach(problems, variants, out_dir.parent, opts)
    results, rep = run_grid(problems, variants, opts, out_dir, predictions.digest if predictions else None, desc=target)
    names = [v.name for v in variants]
    cells = {(p.key, v.name): summarize_runs(results[(p.key, v.name)]["runs"]) for p in problems for v in variants}
    means = {k: c["steps"]["mean"] for k, c in cells.items()}
    # ---- markdown
    md = [_header(f"{target}: convergence steps of Q-learning methods on fixed test maps", opts, info, predictions,
                  variants=variants)]
    md.append("Maps (`src/ndrql/experiments/maps_table3.json`):\n")
    md.append(md_table(["map", "sample", "category", "A* moves (50x50)", "NDR-QI thd", "why"],
                       [[lab, f"{p.split} {p.index}", p.category, p.astar,
                         stats.fmt(results[(p.key, names[-1])]["threshold"], 2), r.reason]
                        for lab, p, r in zip(labels, problems, [r for r in refs if any(q.key == r.key for q in problems)])],
                       ["l", "l", "l", "r", "r", "l"]))
    md.append(f"\n## Convergence steps, mean over {opts.seeds} seeds (converged runs; paper: one run)\n")
    header = ["method"] + labels
    rows = []
    for m in names:
        rows.append([f"**{m}**"] + [stats.fmt(means[(p.key, m)]) +
                                    ("" if cells[(p.key, m)]["not_converged"] == 0 else f" ({cells[(p.key, m)]['not_converged']} n.c.)")
                                    for p in problems])
        if m in paper:
            rows.append([f"{m} (paper)"] + [stats.fmt(paper[m][i]) for i in range(len(problems))])
    md.append(md_table(header, rows))
    md.append("\nMedian convergence steps:\n")
    md.append(md_table(header, [[m] + [stats.fmt(cells[(p.key, m)]["steps"]["median"]) for p in problems] for m in names]))
    if "QL" in names:
        md.append("\n## Improvement over QL\n")
        md.append("Pooled = 1 - sum of per-map mean steps / the same sum for QL (the definition that gives the "
                  "paper's 90/80/58% from its own Table 3); per-map = mean of 1 - steps/QL steps.\n")
        hdr = ["method", "pooled (ours)", "per-map mean (ours)", "maps"] + (["paper"] if paper_improvement else [])
        md.append(md_table(hdr, improvement_rows(names, [p.key for p in problems], means, paper_improvement)))
    else:
        md.append("\n## Improvement over the paper's QL row\n")
        md.append("No QL row here; see table3 for our QL on the same maps and seeds.\n")
    md.append("\n## Per map\n")
    for lab, p in zip(labels, problems):
        i = labels.index(lab)
        pp = {m: paper_paths[m][i] for m in paper_paths} if paper_paths else None
        md.append(f"\n### {lab}: {p.split} {p.index} ({p.category}), A* = {p.astar} moves\n")
        md.append(detail_table(names, {m: cells[(p.key, m)] for m in names}, pp))
    md.append("\nColumns: *converged* = runs whose greedy path was stable for W = 20 episodes within "
              f"{opts.ql.max_episodes} episodes; steps statistics over converged runs (Student-t 95% CI of the mean); "
              "*greedy / A\\** = converged greedy path length over the A* optimum on the same 50x50 grid; "
              "*shortest / longest* = fewest / most moves of the training episodes that reached the goal "
              "up to convergence (the paper's 'shortest / longest distance'), averaged over seeds.\n")
    # ---- figures
    figs = []
    fig = _maps_figure(problems, labels, variants, results, predictions)
    figs.append(save_figure(fig, out_dir / "maps_paths.png"))
    for lab, p in zip(labels, problems):
        fig = _curves_figure(p, lab, variants if len(variants) <= 4 else variants[-4:], results, opts)
        figs.append(save_figure(fig, out_dir / f"curves_{lab}.png"))
    md.append("\n## Figures\n")
    md += [f"![{f.stem}]({f.name})" for f in figs]
    path = write_text(out_dir / f"{target}.md", "\n".join(md) + "\n")
    summary = {"target": target, "machine": info, "options": {"seeds": opts.seed_list, "ql": asdict(opts.ql),
                                                             "priors": asdict(opts.priors), "preset": _preset_json(opts)},
               "weights": predictions.describe() if predictions else None, "skipped": skipped,
               "maps": [{"label": lab, "key": p.key, "category": p.category, "astar": p.astar} for lab, p in zip(labels, problems)],
               "cells": {f"{k[0]}|{k[1]}": v for k, v in cells.items()}}
    write_json(out_dir / "summary.json", summary, indent=1, strict=False)
    log(f"{target}: {len(rep.computed)} tasks computed, {len(rep.reused)} reused, {rep.seconds:.0f} s")
    return path


def table3(opts: SweepOptions, out_dir: str | Path, log: Callable[[str], None] = print) -> Path:
    """Table 3: QL, O-QL, IQL, NDR-QL on the 8 fixed maps."""
    paper = paper_table("table3")
    return fixed_map_table("table3", [get_method(m) for m in TABLE3_METHODS], 8, opts, out_dir,
                           paper["steps"], paper["paths"], paper["improvement"], log)


def table2(opts: SweepOptions, out_dir: str | Path, log: Callable[[str], None] = print) -> Path:
    """Table 2: the D-C / N-C / D-Q / N-Q ablation on MAP-1..MAP-5."""
    return fixed_map_table("table2", TABLE2_ROWS, 5, opts, out_dir, paper_table("table2")["steps"], None, None, log)


# -------------------------------------------------------------------------------------- scale


def scale_refs(per_category: int) -> list[tuple[str, int]]:
    """``per_category`` samples from each of the 4 categories of SEEN and of UNSEEN, evenly spaced
    through each block of 300 (indices ``block * 300 + k * (300 // per_category)``)."""
    if not 1 <= per_category <= 300:
        raise ValueError(f"per_category must be in 1..300, got {per_category}")
    step = 300 // per_category
    return [(split, b * 300 + k * step) for split in ("seen", "unseen") for b in range(4) for k in range(per_category)]


def scale(opts: SweepOptions, out_dir: str | Path, per_category: int = 50, log: Callable[[str], None] = print) -> Path:
    """Table 3's comparison (plus A*) on ``8 * per_category`` test samples: success, steps, optimality gap."""
    from tqdm import tqdm

    from ndrql.errors import NoPathError

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    info = machine()
    root = resolve_root(opts.data)
    refs = scale_refs(per_category)
    problems, skipped = [], []
    for split, index in tqdm(refs, desc="load samples", unit="map", disable=not opts.progress):
        try:
            problems.append(load_problem(root, split, index))
        except NoPathError as exc:
            skipped.append({"split": split, "index": index, "reason": str(exc)})
    variants = [get_method(m) for m in TABLE3_METHODS]
    problems, predictions = _attach(problems, variants, out_dir.parent, opts)
    results, rep = run_grid(problems, variants, opts, out_dir, predictions.digest if predictions else None,
                            desc="scale", records=False)
    names = [v.name for v in variants]
    groups: dict[str, list[Problem]] = {"all": problems}
    for split in ("seen", "unseen"):
        groups[split] = [p for p in problems if p.split == split]
        for cat in dict.fromkeys(p.category for p in problems if p.split == split):
            groups[f"{split}/{cat}"] = [p for p in problems if p.split == split and p.category == cat]
    md = [_header(f"scale: {', '.join(names)} and A* on {len(refs)} test samples", opts, info, predictions,
                  f"Samples: {per_category} per category, evenly spaced in each block of 300 "
                  f"(`scale_refs({per_category})`); {len(skipped)} skipped as disconnected on the planning grid "
                  f"({', '.join(s['split'] + ' ' + str(s['index']) for s in skipped) or 'none'}).", variants)]
    agg: dict[str, dict] = {}
    for gname, ps in groups.items():
        if not ps:
            continue
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
        agg[gname] = gm
    header = ["group", "method", "maps", "success (converged runs)", "steps mean", "median", "95% CI",
              "improvement over QL (pooled / per-map)", "greedy/A* - 1: mean", "p90", "optimal paths"]
    rows = []
    for gname, gm in agg.items():
        for m in names:
            a = gm[m]
            imp = "-" if m == "QL" else f"{_pct(a['improvement_pooled'])} / {_pct(a['improvement_per_map'])}"
            rows.append([gname, m, a["maps"], f"{_pct(a['success_rate'])} ({a['converged']}/{a['runs']})",
                         stats.fmt(a["steps"]["mean"]), stats.fmt(a["steps"]["median"]), stats.fmt_ci(a["steps"]), imp,
                         stats.fmt(a["gap"]["mean"], 3), stats.fmt(a["gap_p90"], 3), _pct(a["optimal_share"])])
        rows.append([gname, "A*", len(groups[gname]), "100%", "-", "-", "-", "-", "0", "0", "100%"])
    md.append("\n## Results\n")
    md.append(md_table(header, rows, ["l", "l"] + ["r"] * (len(header) - 2)))
    md.append("\nSuccess = runs that converged (docs/method.md) within the episode budget; steps over converged runs "
              "(pooled over maps and seeds, Student-t 95% CI); optimality gap = converged greedy path / A* - 1 "
              "on the same 50x50 grid (A* is optimal by construction: gap 0 on every connected sample).\n")
    # ---- figures
    figs = [save_figure(_scale_figure(agg, names, groups), out_dir / "scale.png"),
            _scale_distributions(problems, names, results, out_dir)]
    md.append("\n## Figures\n")
    md += [f"![{f.stem}]({f.name})" for f in figs]
    path = write_text(out_dir / "scale.md", "\n".join(md) + "\n")
    write_json(out_dir / "summary.json", {"machine": info, "skipped": skipped, "groups": agg, "preset": _preset_json(opts),
                                          "weights": predictions.describe() if predictions else None},
               indent=1, strict=False)
    log(f"scale: {len(rep.computed)} tasks computed, {len(rep.reused)} reused, {rep.seconds:.0f} s")
    return path


def _scale_figure(agg: dict, names: Sequence[str], groups: dict) -> Any:
    """Per category: mean convergence steps (bars, log scale) and mean optimality gap per method."""
    from ndrql.viz.maps import new_figure
    from ndrql.viz.overlays import METHOD_COLORS

    cats = [g for g in agg if "/" in g]
    fig = new_figure(figsize=(12, 7))
    ax1, ax2 = fig.subplots(2, 1)
    w = 0.8 / len(names)
    x = np.arange(len(cats))
    for i, m in enumerate(names):
        ax1.bar(x + i * w, [agg[c][m]["steps"]["median"] or 0 for c in cats], w, label=m, color=METHOD_COLORS.get(m))
        ax2.bar(x + i * w, [agg[c][m]["gap"]["mean"] or 0 for c in cats], w, label=m, color=METHOD_COLORS.get(m))
    for ax in (ax1, ax2):
        ax.set_xticks(x + 0.4 - w / 2, [c.replace("/", "\n") for c in cats], fontsize=7)
    ax1.set_yscale("log")
    ax1.set_ylabel("median convergence steps")
    ax2.set_ylabel("mean greedy/A* - 1")
    ax1.legend(fontsize=8, ncol=len(names))
    return fig


def _scale_distributions(problems: Sequence[Problem], names: Sequence[str], results: dict, out_dir: Path) -> Path:
    """Distributions over all runs: convergence steps (ECDF, log x) and optimality gap (histogram)."""
    from ndrql.viz.maps import new_figure
    from ndrql.viz.overlays import METHOD_COLORS

    fig = new_figure(figsize=(12, 4.5))
    ax1, ax2 = fig.subplots(1, 2)
    for m in names:
        runs = [r for p in problems for r in results[(p.key, m)]["runs"] if r["converged"]]
        st = np.sort([r["convergence_steps"] for r in runs])
        if st.size:
            ax1.step(st, np.arange(1, st.size + 1) / st.size, where="post", label=m, color=METHOD_COLORS.get(m))
        gaps = [r["length_ratio"] - 1 for r in runs]
        ax2.hist(gaps, bins=np.linspace(0, 1, 41), histtype="step", label=m, color=METHOD_COLORS.get(m))
    ax1.set_xscale("log")
    ax1.set_xlabel("convergence steps")
    ax1.set_ylabel("fraction of converged runs")
    ax2.set_xlabel("greedy path / A* - 1")
    ax2.set_ylabel("runs")
    ax2.set_yscale("log")
    ax1.legend(fontsize=8)
    return save_figure(fig, out_dir / "scale_distributions.png")
