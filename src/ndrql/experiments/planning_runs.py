"""Running the planning tables: options, one sweep task per (map, method), statistics per cell.

Tables 2 and 3, ``scale`` and ``dynamic`` run Q-learning methods on dataset maps with many seeds.
Every (map, method) pair is one sweep task running all seeds (:mod:`ndrql.experiments.sweep`), so
a killed run resumes where it stopped and any executor gives the same table. Per method and map
the tables report mean, median and 95% CI of convergence steps over the converged runs, the number
that did not converge, the greedy path against A*, and the paper-style shortest/longest training
path (:func:`summarize_runs`).
"""

from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from tqdm import tqdm

from ndrql.experiments import stats
from ndrql.experiments.digests import array_digest, fingerprint
from ndrql.experiments.presets import method_configs
from ndrql.pipeline.samples import PredictionCache, Problem
from ndrql.experiments.sweep import SweepReport, Task, run_sweep
from ndrql.planning import kernel
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import Method, build_priors
from ndrql.planning.preset import preset_to_dict
from ndrql.planning.runner import run_plan

#: Bump when a change in this module changes task results (forces recomputation of stored tasks).
TASK_VERSION = 1


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


def preset_json(opts: SweepOptions) -> dict | None:
    """The preset of ``opts`` as JSON (``None`` without one), for ``summary.json``."""
    return None if opts.preset is None else preset_to_dict(opts.preset)


def method_fields(m: Method) -> dict[str, Any]:
    """What of a method determines its runs (its name and priors; the description does not), for fingerprints."""
    return {"name": m.name, "d_crf": m.d_crf, "n_crf": m.n_crf, "d_qi": m.d_qi, "n_qi": m.n_qi,
            "qi_mask_only": m.qi_mask_only}


def plan_task(blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int], method: Method,
              seeds: list[int], ql: QLConfig, pc: PriorConfig, region: np.ndarray | None,
              guideline: np.ndarray | None, records_seed: int | None = None) -> dict[str, Any]:
    """All seeds of one method on one planning grid -> JSON-able dict (the sweep's unit of work)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pri = build_priors(method, blocked, start, goal, region, guideline, pc)
    runs = []
    for s in seeds:
        r = run_plan(blocked, start, goal, method, s, ql, pc, priors=pri, keep_records=(s == records_seed))
        runs.append(r.to_dict(include_records=(s == records_seed)))
    return {"variant": method.name, "threshold": pri.threshold, "warnings": [str(w.message) for w in caught],
            "runs": runs}


def make_tasks(problems: Sequence[Problem], methods: Sequence[Method], opts: SweepOptions,
               weights_digest: str | None, records: bool = True) -> list[Task]:
    """One :func:`plan_task` per (problem, method), keyed ``<problem>__<method>``, records of ``seed0`` kept."""
    tasks = []
    for p in problems:
        for m in methods:
            region = p.region if m.needs_ndr else None
            guideline = p.guideline if m.needs_ndr else None
            if m.needs_ndr and (region is None or guideline is None):
                raise ValueError(f"{p.key}: method {m.name} needs predictions; attach them first")
            rec = opts.seed0 if records else None
            ql, pc = method_configs(opts, m.name)
            fp = fingerprint(TASK_VERSION, p.key, array_digest(p.blocked), p.start, p.goal, method_fields(m),
                             opts.seed_list, asdict(ql), asdict(pc), weights_digest if m.needs_ndr else None, rec)
            key = f"{p.key}__{m.name}".replace(" ", "_")
            tasks.append(Task(key, plan_task, (p.blocked, p.start, p.goal, m, opts.seed_list, ql,
                                               pc, region, guideline, rec), fp))
    return tasks


def run_grid(problems: Sequence[Problem], methods: Sequence[Method], opts: SweepOptions, out_dir: Path,
             weights_digest: str | None, desc: str,
             records: bool = True) -> tuple[dict[tuple[str, str], dict], SweepReport]:
    """Run (or resume) every (problem, method) task; results by ``(problem key, method name)``
    and the sweep's :class:`~ndrql.experiments.sweep.SweepReport`."""
    kernel.warm_up()  # compile/load once before forking workers
    tasks = make_tasks(problems, methods, opts, weights_digest, records)
    rep = run_sweep(tasks, out_dir / "tasks", executor=opts.executor, workers=opts.workers,
                    progress=opts.progress, desc=desc, ray_address=opts.ray_address)
    out = {}
    it = iter(rep.results.values())
    for p in problems:
        for m in methods:
            out[(p.key, m.name)] = next(it)
    return out, rep


def attach_predictions(problems: list[Problem], methods: Sequence[Method], out_root: Path,
                       opts: SweepOptions) -> tuple[list[Problem], PredictionCache | None]:
    """``problems`` with the NDR predictions on their grids when a method needs them (cached under
    ``<out_root>/predictions``), and the cache (``None`` when no method needs the model)."""
    if not any(m.needs_ndr for m in methods):
        return problems, None
    predictions = PredictionCache(out_root / "predictions", opts.weights)
    out = [predictions.attach(p) for p in tqdm(problems, desc="NDR predictions", unit="map", disable=not opts.progress)]
    return out, predictions


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
