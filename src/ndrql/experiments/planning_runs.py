"""Running the planning tables: options, one sweep task per (map, method), statistics per cell.

Tables 2 and 3, ``scale`` and ``dynamic`` run Q-learning methods on dataset maps with many seeds.
Every (map, method) pair is one sweep task running all seeds (:mod:`ndrql.experiments.sweep`), so
a killed run resumes where it stopped and any executor gives the same table. Per method and map
the tables report mean, median and 95% CI of convergence steps over the converged runs, the number
that did not converge, the greedy path against A*, and the paper-style shortest/longest training
path (:func:`summarize_runs`).

Where the NDR rows' priors come from is the table's **prior source**: the model (a
:class:`~ndrql.pipeline.samples.PredictionCache` of its weights) or the oracle
(:class:`~ndrql.pipeline.samples.OraclePriors`, a diagnostic). A table may also run some methods a
second time with the oracle's priors (``oracle_rows``): the same maps, seeds and constants, a row named
``"<method> (oracle priors)"``, and the model's share of the oracle's reduction (:func:`oracle_share`).
Task fingerprints carry the prior source (the weights' digest, or the oracle's arrays), and oracle
tasks' keys end in ``+oracle``, so the two never reuse each other's results.
"""

from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from tqdm import tqdm

from ndrql.errors import NdrqlError
from ndrql.experiments import stats
from ndrql.experiments.digests import array_digest, fingerprint
from ndrql.experiments.presets import method_configs
from ndrql.experiments.sweep import SweepReport, Task, run_sweep
from ndrql.maps.grid import PLANNING_SIZE
from ndrql.model.symmetry import DEFAULT_COUNT as DEFAULT_SYMMETRIES
from ndrql.pipeline.samples import OraclePriors, PredictionCache, Problem
from ndrql.planning import compiled
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import Method, build_priors
from ndrql.planning.preset import preset_to_dict
from ndrql.planning.runner import run_plan
from ndrql.synth.oracle import ORACLE_NAME, PRIOR_SOURCES

#: Bump when a change in this module changes task results (forces recomputation of stored tasks).
TASK_VERSION = 1

#: The name of a method's row when it runs with the oracle's priors beside the model's.
ORACLE_LABEL = f" ({ORACLE_NAME})"
#: The end of the task key of a run with the oracle's priors.
ORACLE_KEY = "+oracle"


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
    prior_from: str = "model"
    """Priors of the NDR rows: ``model`` (``weights``) or ``oracle`` (an 8-connected shortest path of the grid with shortcuts, drawn as the labels are; a diagnostic)."""
    symmetries: int = DEFAULT_SYMMETRIES
    """A grid-mode model's prediction is averaged over this many orientations of the grid, as ``ndrql plan`` does
    (map-mode models, the paper's, are never averaged)."""

    @property
    def seed_list(self) -> list[int]:
        return list(range(self.seed0, self.seed0 + self.seeds))


def preset_json(opts: SweepOptions) -> dict | None:
    """The preset of ``opts`` as JSON (``None`` without one), for ``summary.json``."""
    return None if opts.preset is None else preset_to_dict(opts.preset)


def method_fields(m: Method) -> dict[str, Any]:
    """What of a method determines its runs (its name and priors; the description does not), for fingerprints."""
    return {"name": m.name, "d_crf": m.d_crf, "n_crf": m.n_crf, "d_qi": m.d_qi, "n_qi": m.n_qi,
            "qi_mask_only": m.qi_mask_only, **({"exact_distance": True} if m.exact_distance else {}),
            **({"model_distance": True} if m.model_distance else {})}


def plan_task(blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int], method: Method,
              seeds: list[int], ql: QLConfig, pc: PriorConfig, region: np.ndarray | None,
              guideline: np.ndarray | None, records_seed: int | None = None,
              distance: np.ndarray | None = None) -> dict[str, Any]:
    """All seeds of one method on one planning grid -> JSON-able dict (the sweep's unit of work);
    ``distance``: the model's goal distance for Eq. 6 (a model with a distance head)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pri = build_priors(method, blocked, start, goal, region, guideline, pc, distance)
    runs = []
    for s in seeds:
        r = run_plan(blocked, start, goal, method, s, ql, pc, priors=pri, keep_records=(s == records_seed))
        runs.append(r.to_dict(include_records=(s == records_seed)))
    return {"variant": method.name, "threshold": pri.threshold, "warnings": [str(w.message) for w in caught],
            "runs": runs}


def is_oracle(source: Any) -> bool:
    """Whether ``source`` (a prediction cache, oracle priors or ``None``) is the oracle."""
    return getattr(source, "prior_from", None) == "oracle"


def prior_id(source: Any, p: Problem) -> str | None:
    """Where ``p``'s priors come from, for fingerprints: the weights' digest of a prediction cache, or
    ``oracle:`` and the digest of the oracle's arrays; ``None`` without a source."""
    if source is None:
        return None
    if is_oracle(source):
        return "oracle:" + array_digest(np.asarray(p.region, np.float64), np.asarray(p.guideline, np.float64))
    return source.digest


def make_tasks(problems: Sequence[Problem], methods: Sequence[Method], opts: SweepOptions,
               source: Any = None, records: bool = True) -> list[Task]:
    """One :func:`plan_task` per (problem, method), keyed ``<problem>__<method>`` (``+oracle`` after it for an
    NDR method with the oracle's priors), records of ``seed0`` kept. ``source``: where the attached
    priors come from (:func:`prior_id`)."""
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
                             opts.seed_list, asdict(ql), asdict(pc), prior_id(source, p) if m.needs_ndr else None, rec)
            key = f"{p.key}__{m.name}".replace(" ", "_") + (ORACLE_KEY if m.needs_ndr and is_oracle(source) else "")
            distance = p.distance if m.needs_distance else None
            tasks.append(Task(key, plan_task, (p.blocked, p.start, p.goal, m, opts.seed_list, ql,
                                               pc, region, guideline, rec, distance), fp))
    return tasks


def run_grid(problems: Sequence[Problem], methods: Sequence[Method], opts: SweepOptions, out_dir: Path,
             source: Any, desc: str, records: bool = True,
             oracle_rows: Sequence[Method] = ()) -> tuple[dict[tuple[str, str], dict], SweepReport]:
    """Run (or resume) every (problem, method) task, in one sweep with every method of ``oracle_rows`` run
    again with the oracle's priors; results by ``(problem key, row name)`` (an oracle row is named
    ``<method> (oracle priors)``) and the sweep's :class:`~ndrql.experiments.sweep.SweepReport`.
    ``source``: where the priors attached to ``problems`` come from (:func:`prior_id`)."""
    compiled.warm_up()  # compile/load once before forking workers
    tasks = make_tasks(problems, methods, opts, source, records)
    rows = [(p.key, m.name) for p in problems for m in methods]
    if oracle_rows:
        oracle = OraclePriors()
        tasks += make_tasks([oracle.attach(p) for p in problems], oracle_rows, opts, oracle, records)
        rows += [(p.key, m.name + ORACLE_LABEL) for p in problems for m in oracle_rows]
    rep = run_sweep(tasks, out_dir / "tasks", executor=opts.executor, workers=opts.workers,
                    progress=opts.progress, desc=desc, ray_address=opts.ray_address)
    return dict(zip(rows, rep.results.values())), rep


def attach_predictions(problems: list[Problem], methods: Sequence[Method], out_root: Path, opts: SweepOptions,
                       grid: int = PLANNING_SIZE) -> tuple[list[Problem], PredictionCache | OraclePriors | None]:
    """``problems`` with the NDR priors on their grids when a method needs them, and where they came from
    (``None`` when no method needs them): the model's predictions (cached under ``<out_root>/predictions``,
    ``predictions/grid<n>`` for a planning grid of ``n`` cells other than the paper's) or, with
    ``opts.prior_from == "oracle"``, the oracle's priors."""
    if not any(m.needs_ndr for m in methods):
        return problems, None
    if opts.prior_from not in PRIOR_SOURCES:
        raise NdrqlError(f"unknown prior source {opts.prior_from!r}; valid: {', '.join(PRIOR_SOURCES)}")
    if opts.prior_from == "oracle":
        source: PredictionCache | OraclePriors = OraclePriors()
    else:
        source = PredictionCache(out_root / "predictions" / ("" if grid == PLANNING_SIZE else f"grid{grid}"), opts.weights,
                                 symmetries=opts.symmetries)
    out = [source.attach(p) for p in tqdm(problems, desc="NDR predictions", unit="map", disable=not opts.progress)]
    return out, source


def oracle_share(results: dict[tuple[str, str], dict], keys: Sequence[str], row: str = "NDR-QL") -> dict[str, Any]:
    """QL, ``row`` and its oracle row on the maps ``keys``: steps pooled over maps and seeds (a run that did not
    converge counts the steps it ran), each row's reduction against QL and the share
    (:func:`~ndrql.experiments.stats.share_of_oracle`). Raises when the rows did not run the same seeds."""
    names = ("QL", row, row + ORACLE_LABEL)
    for k in keys:
        seeds = {n: [r["seed"] for r in results[(k, n)]["runs"]] for n in names}
        if len({tuple(v) for v in seeds.values()}) != 1:
            raise NdrqlError(f"{k}: rows ran different seeds {seeds}; the share needs the same runs")
    per_map = {n: [sum(stats.run_steps(r) for r in results[(k, n)]["runs"]) for k in keys] for n in names}
    ql = per_map["QL"]
    return {"maps": len(keys), "steps": {n: int(sum(v)) for n, v in per_map.items()},
            "vs_ql": {n: -stats.relative_improvement(per_map[n], ql) for n in names[1:]},
            "share": stats.share_of_oracle(per_map[row], per_map[names[2]], ql)}


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
