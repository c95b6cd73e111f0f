"""The dynamic scenarios of the paper's Fig. 5, with numbers: re-planning after a change.

(a) **obstacles change**, start and goal fixed: blocks are added on the current optimal path, then
removed again, one change per stage. At every stage the NDR prediction is recomputed on the new map
and Q-learning runs twice: from scratch (the method's priors on the new map) and warm-started (the
Q-table the previous stage converged to, with the new stage's rewards).

(b) **the agent advances**: it walks along the converged NDR-QL path (seed ``seed0``) and re-plans
from each new position with the goal fixed, again from scratch and warm-started.

Methods: QL and NDR-QL. Every seed is a chain of stages (one sweep task), so the table is the same
whatever the executor; the numbers are steps to (re-)converge (docs/method.md).
"""

from __future__ import annotations

import warnings
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ndrql.errors import NoPathError
from ndrql.experiments import stats
from ndrql.experiments.digests import fingerprint
from ndrql.experiments.planning_runs import SweepOptions, method_fields
from ndrql.experiments.presets import method_configs
from ndrql.dataset.layout import resolve_root
from ndrql.experiments.problems import table3_maps
from ndrql.pipeline.samples import PredictionCache, Problem, load_problem
from ndrql.experiments.report import machine, machine_line, md_table, preset_line, save_figure
from ndrql.experiments.sweep import Task, run_sweep
from ndrql.io import write_json, write_text
from ndrql.maps.astar import astar4
from ndrql.maps.grid import PlanningGrid, cell_to_point
from ndrql.maps.problem import MapProblem
from ndrql.planning import compiled
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import Method, Priors, build_priors, get_method
from ndrql.planning.runner import run_plan
from ndrql.viz.reproduce import dynamic_figure

DYNAMIC_VERSION = 1
METHODS = ("QL", "NDR-QL")


def _with_map(p: Problem, obstacles: np.ndarray, source_start=None) -> Problem:
    """``p`` on a changed map and/or from a new start (planning grid, A* recomputed)."""
    s = tuple(source_start) if source_start is not None else p.source_start
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pg = PlanningGrid.from_map(obstacles, s, p.source_goal, size=p.blocked.shape)
    opt = int(astar4(pg.blocked, pg.start, pg.goal).moves)
    return replace(p, source=MapProblem(obstacles, s, p.source_goal), blocked=np.array(pg.blocked), start=tuple(pg.start),
                   goal=tuple(pg.goal), astar=opt, region=None, guideline=None)


def obstacle_stages(p: Problem, block_cells: int = 3) -> list[tuple[str, Problem]]:
    """Scenario (a): base map, + block on the A* path at 1/3, + block at 2/3, - first block, - second.

    A block is ``block_cells`` x ``block_cells`` planning cells of obstacle pixels, centred on a path
    cell; when it would disconnect start and goal, the next path cell is tried.
    """
    path = astar4(p.blocked, p.start, p.goal).path
    h, w = p.obstacles.shape
    half = block_cells * h / p.blocked.shape[0] / 2

    def block_at(base: np.ndarray, frac: float) -> tuple[np.ndarray, tuple[int, int]]:
        i0 = int(frac * (len(path) - 1))
        for i in list(range(i0, len(path) - 3)) + list(range(i0 - 1, 3, -1)):
            r, c = cell_to_point(path[i], (h, w), p.blocked.shape)
            r0, r1 = int(max(0, r - half)), int(min(h, r + half + 1))
            c0, c1 = int(max(0, c - half)), int(min(w, c + half + 1))
            new = base.copy()
            new[r0:r1, c0:c1] = True
            if new[p.source_start] or new[p.source_goal]:
                continue
            try:
                _with_map(p, new)
            except NoPathError:
                continue
            return new, tuple(int(x) for x in path[i])  # type: ignore[return-value]
        raise NoPathError("no place on the path where a block keeps start and goal connected")

    base = p.obstacles
    a, cell_a = block_at(base, 1 / 3)
    ab, cell_b = block_at(a, 2 / 3)
    only_b = ab & ~(a & ~base)  # remove block A (keep original obstacles)
    stages = [("initial map", base), (f"+ block at cell {cell_a}", a), (f"+ block at cell {cell_b}", ab),
              (f"- block at {cell_a}", only_b), (f"- block at {cell_b} (initial map)", base)]
    return [(label, _with_map(p, obs)) for label, obs in stages]


def advance_stages(p: Problem, path: Sequence[Sequence[int]], n: int = 5) -> list[tuple[str, Problem]]:
    """Scenario (b): the agent at ``n`` points along ``path`` (planning cells), the last one short of
    the goal; the start moves, map and goal stay."""
    L = len(path) - 1
    idx = sorted(set(int(round(k * L / n)) for k in range(n)))
    out = []
    for i in idx:
        r, c = cell_to_point(path[i], p.obstacles.shape, p.blocked.shape)
        src = p.source_start if i == 0 else (int(round(r)), int(round(c)))
        out.append((f"agent after {i} moves", _with_map(p, p.obstacles, src)))
    return out


def chain_task(stages: list[tuple[np.ndarray, tuple, tuple, Any, Any]], method: Method, seed: int, ql: QLConfig,
               pc: PriorConfig) -> list[dict]:
    """One seed through every stage: scratch and warm-started runs (module docstring)."""
    out = []
    prev_q = None
    for k, (blocked, start, goal, region, guideline) in enumerate(stages):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            pri = build_priors(method, blocked, start, goal, region, guideline, pc)
        scratch = run_plan(blocked, start, goal, method, seed, ql, pc, priors=pri, keep_q=True)
        if prev_q is None:
            warm = scratch
        else:
            warm = run_plan(blocked, start, goal, method, seed, ql, pc,
                        priors=Priors(pri.r_c, prev_q, pri.threshold), keep_q=True)
        prev_q = warm.q_table
        keep = ("converged", "convergence_steps", "convergence_episode", "path_length", "astar_length", "length_ratio", "path")
        out.append({"scratch": {k2: scratch.to_dict()[k2] for k2 in keep},
                    "warm": {k2: warm.to_dict()[k2] for k2 in keep}})
    return out


def _stage_tuple(p: Problem, needs_ndr: bool):
    return (p.blocked, p.start, p.goal, p.region if needs_ndr else None, p.guideline if needs_ndr else None)


def dynamic(opts: SweepOptions, out_dir: str | Path, map_label: str = "MAP-1", log: Callable[[str], None] = print) -> Path:
    """Both scenarios on one of the fixed maps; writes ``dynamic.md``, ``summary.json``, figures."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    info = machine()
    root = resolve_root(opts.data)
    ref = next(r for r in table3_maps() if r.label == map_label)
    base = load_problem(root, ref.split, ref.index)
    preds = PredictionCache(out_dir.parent / "predictions", opts.weights)
    scen_a = obstacle_stages(base)
    # (b): the agent follows the converged NDR-QL path of seed0 on the initial map.
    b0 = preds.attach(base)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r0 = run_plan(b0.blocked, b0.start, b0.goal, "NDR-QL", opts.seed0, *method_configs(opts, "NDR-QL"),
                  region=b0.region, guideline=b0.guideline)
    scen_b = advance_stages(base, r0.path or [])
    scenarios = {"a": scen_a, "b": scen_b}
    # predictions for every stage (map changes need a fresh prediction; cache key by content)
    attached: dict[str, list[tuple[str, Problem]]] = {}
    for name, stages in scenarios.items():
        lst = []
        for i, (label, p) in enumerate(stages):
            # same sample id on a changed map: one cache folder per stage (the cache also checks the inputs)
            cache = PredictionCache(out_dir / "predictions" / f"{name}{i}", opts.weights)
            lst.append((label, cache.attach(p)))
        attached[name] = lst
    compiled.warm_up()
    tasks = []
    variants = [get_method(m) for m in METHODS]
    for name, stages in attached.items():
        for v in variants:
            st = [_stage_tuple(p, v.needs_ndr) for _, p in stages]
            ql, pc = method_configs(opts, v.name)
            for s in opts.seed_list:
                fp = fingerprint(DYNAMIC_VERSION, name, [(p.key, p.start, p.goal, int(p.blocked.sum())) for _, p in stages],
                                 method_fields(v), s, asdict(ql), asdict(pc), preds.digest if v.needs_ndr else None)
                tasks.append(Task(f"{name}__{v.name}__{s}", chain_task, (st, v, s, ql, pc), fp))
    rep = run_sweep(tasks, out_dir / "tasks", executor=opts.executor, workers=opts.workers, progress=opts.progress,
                    desc="dynamic", ray_address=opts.ray_address)
    res = rep.results
    md = [f"# dynamic: re-planning after changes ({map_label}: {base.split} {base.index}, {base.category})", "",
          f"Command: `{opts.command}`" if opts.command else "", "", f"Machine: {machine_line(info)}.", "",
          f"Seeds {opts.seed0}..{opts.seed0 + opts.seeds - 1}; NDR weights `{preds.weights}` (sha256 {preds.digest}). "
          "Steps = environment steps until the greedy path is stable for W = 20 episodes (docs/method.md); "
          "warm = Q-table of the previous stage's (warm) run as Q0, rewards of the new stage; "
          "scratch = the method's own priors on the new stage."]
    if opts.preset is not None:
        md += ["", preset_line(opts, list(METHODS))]
    summary: dict[str, Any] = {"machine": info, "map": ref.key, "scenarios": {}}
    titles = {"a": "(a) obstacles added and removed, start and goal fixed",
              "b": "(b) the agent advances along its path, goal fixed"}
    for name, stages in attached.items():
        md.append(f"\n## {titles[name]}\n")
        header = ["stage", "A*"] + [f"{m} {kind}" for m in METHODS for kind in ("scratch", "warm")] + \
                 [f"{m} warm/scratch" for m in METHODS]
        rows = []
        summ = []
        for i, (label, p) in enumerate(stages):
            row: list[Any] = [label, p.astar]
            cell: dict[str, Any] = {"stage": label, "astar": p.astar}
            for m in METHODS:
                for kind in ("scratch", "warm"):
                    runs = [res[f"{name}__{m}__{s}"][i][kind] for s in opts.seed_list]
                    d = stats.describe([r["convergence_steps"] for r in runs])
                    ratio = stats.describe([r["length_ratio"] for r in runs if r["converged"]])
                    cell[f"{m}/{kind}"] = {"steps": d, "ratio": ratio}
                    nc = f" ({d['missing']} n.c.)" if d["missing"] else ""
                    row.append(f"{stats.fmt(d['mean'])} {stats.fmt_ci(d)}{nc}" if i else f"{stats.fmt(d['mean'])}{nc}")
            for m in METHODS:
                a, b = cell[f"{m}/warm"]["steps"]["mean"], cell[f"{m}/scratch"]["steps"]["mean"]
                row.append("-" if (i == 0 or a is None or b is None) else f"{a / b:.2f}")
            rows.append(row)
            summ.append(cell)
        md.append(md_table(header, rows))
        md.append("\nMean steps and 95% CI over seeds; stage 0 is the from-scratch plan both chains start from. "
                  "Greedy path / A* of the warm runs (mean): " + ", ".join(
                      f"{m}: " + " / ".join(stats.fmt(c[f"{m}/warm"]["ratio"]["mean"], 2) for c in summ) for m in METHODS))
        summary["scenarios"][name] = summ
    panels = []  # per scenario and stage: title, problem and the warm-started NDR-QL run of seed0
    for name, stages in attached.items():
        warm = [stage["warm"] for stage in res[f"{name}__NDR-QL__{opts.seed0}"]]
        panels.append([(f"{label}\nwarm {stats.fmt(run['convergence_steps'])} steps", p, run)
                       for (label, p), run in zip(stages, warm)])
    f1 = save_figure(dynamic_figure(panels), out_dir / "fig5_dynamic.png")
    md.append("\n## Figures\n")
    md.append(f"![{f1.stem}]({f1.name})\n\nTop: scenario (a), bottom: scenario (b); region (green) and "
              "guideline (red) predicted on each stage's map, the warm-started NDR-QL path (seed "
              f"{opts.seed0}) in white.")
    path = write_text(out_dir / "dynamic.md", "\n".join(md) + "\n")
    write_json(out_dir / "summary.json", summary, indent=1, strict=False)
    log(f"dynamic: {len(rep.computed)} tasks computed, {len(rep.reused)} reused, {rep.seconds:.0f} s")
    return path
