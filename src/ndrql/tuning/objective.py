"""What ``ndrql tune`` measures: planning problems from held-out TRAIN maps, and their evaluation.

**Maps.** The shipped model trained on TRAIN minus a validation split
(:func:`ndrql.dataset.splits.train_val_split` with its checkpoint's ``val_fraction`` 0.05 and
``seed`` 0): whole maps, none of them a TEST/SEEN map. Tuning draws its samples from that split
only (:func:`validation_ids`), so the model's predictions there are as good as on new maps and no
TEST sample is ever read. Samples are taken in a seeded random order; the few whose start and goal
are disconnected on the 50x50 planning grid are skipped and counted.

**Score.** One evaluation runs a method with given constants on every problem and seed
(:func:`evaluate`): *pooled steps* = mean convergence steps over all runs (= the sum the paper's
"improves convergence by 90%" compares, divided by the number of runs), *geometric mean* of the
steps (what a search on maps of many sizes and families minimises: every map weighs alike, a 2x
slow-down counts the same on a small map as on a large one), *ratio* = mean greedy path / A* over
the runs, and the number of runs that did not converge. Runs go in chunks of problems,
so a search can report the running mean after each chunk and prune a hopeless trial early; the
result does not depend on the chunking or on the number of worker processes.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ndrql.dataset.cache import cache_dir, load_split
from ndrql.dataset.splits import train_val_split
from ndrql.errors import NoPathError
from ndrql.maps.astar import astar4
from ndrql.maps.grid import PLANNING_SIZE, PlanningGrid
from ndrql.maps.problem import MapProblem
from ndrql.pipeline.samples import PredictionCache, Problem
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import build_priors, get_method
from ndrql.planning.runner import run_plan


def validation_ids(root: str | Path, val_fraction: float = 0.05, split_seed: int = 0) -> np.ndarray:
    """TRAIN sample indices of the shipped model's validation split (sorted; module docstring)."""
    train = load_split(root, "train", progress=False)
    seen = load_split(root, "seen", progress=False)
    _, val = train_val_split(train, seen, val_fraction=val_fraction, seed=split_seed)
    return np.sort(val)


def pick_samples(ids: Sequence[int], order_seed: int) -> list[int]:
    """``ids`` in a seeded random order (the first K connected ones are used)."""
    rng = np.random.default_rng(order_seed)
    return [int(i) for i in rng.permutation(np.asarray(ids, dtype=np.int64))]


def train_problems(root: str | Path, ids: Sequence[int], k: int, weights: str | None = None,
                   progress: bool = False) -> tuple[list[Problem], list[int], str]:
    """The first ``k`` of TRAIN samples ``ids`` that are connected on the planning grid, with NDR
    predictions attached; also the skipped ids and the weights' digest. Reads TRAIN only."""
    from tqdm import tqdm

    train = load_split(root, "train", progress=False)
    preds = PredictionCache(cache_dir() / "tune" / "predictions", weights)
    out: list[Problem] = []
    skipped: list[int] = []
    bar = tqdm(total=k, desc="validation maps", unit="map", disable=not progress)
    for i in ids:
        if len(out) == k:
            break
        obstacles = train.obstacles(int(i))
        r0, c0, r1, c1 = (int(v) for v in train.points[int(i)])
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                pg = PlanningGrid.from_map(obstacles, (r0, c0), (r1, c1), size=PLANNING_SIZE)
            opt = int(astar4(pg.blocked, pg.start, pg.goal).moves)
        except NoPathError:
            skipped.append(int(i))
            continue
        p = Problem("train", int(i), "", MapProblem(obstacles, (r0, c0), (r1, c1)), np.array(pg.blocked),
                    tuple(pg.start), tuple(pg.goal), opt)  # type: ignore[arg-type]
        out.append(preds.attach(p))
        bar.update(1)
    bar.close()
    return out, skipped, preds.digest


# ------------------------------------------------------------------------------------ evaluation


def run_problem(p: Problem, method: str, seeds: Sequence[int], ql: QLConfig, pc: PriorConfig,
                stop_on_failure: bool = False) -> list[tuple[bool, int, float]]:
    """``(converged, steps, greedy path / A*)`` per seed on one problem (steps: every step of a failed
    run); with ``stop_on_failure`` the seeds after the first run that did not converge are skipped."""
    m = get_method(method)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # NDR-QI's "no threshold connects" warning: the runs show its effect
        pri = build_priors(m, p.blocked, p.start, p.goal, p.region if m.needs_ndr else None,
                           p.guideline if m.needs_ndr else None, pc, p.distance if m.needs_distance else None)
    out = []
    for s in seeds:
        r = run_plan(p.blocked, p.start, p.goal, m, int(s), ql, pc, priors=pri, astar=p.astar)
        ratio = float(r.length_ratio) if r.converged and r.length_ratio is not None else math.nan
        steps = r.convergence_steps if r.converged else r.total_steps  # a failed run counts every step it took
        out.append((bool(r.converged), int(steps), ratio))
        if stop_on_failure and not r.converged:
            break
    return out


PATH_BOUND = 2.0
"""Most greedy path / A* that searched constants may reach on the worst map of the set they were searched on
(the mean over the check seeds on that map). Why 2.0: Q-learning's convergence test (the same greedy path
for 20 episodes) does not make the path optimal, and the paper's own constants already reach about 1.5-1.6
on the worst map of the ``tune`` set (QL 1.53, IQL 1.57 at grid 50: docs/results.md#path-quality), so a
bound at that level would reject a search for noise on one map; a route twice as long as the grid's
shortest is wrong by any user's standard, and that is what a search may not buy fewer steps with (the
near-greedy IQL constants of the ``general`` preset before this bound reached 3.8 on one map). The paper's
constants (the ``spec`` entries) are the reproduction, not a choice: reported whatever their worst map."""


@dataclass
class Evaluation:
    """Runs of one method and set of constants, problem by problem (module docstring)."""

    runs: dict[str, list[tuple[bool, int, float]]] = field(default_factory=dict)
    """Per problem key: ``(converged, steps, ratio)`` per seed."""

    def add(self, key: str, runs: list[tuple[bool, int, float]]) -> None:
        self.runs[key] = [tuple(r) for r in runs]  # type: ignore[misc]

    @property
    def n_runs(self) -> int:
        return sum(len(v) for v in self.runs.values())

    @property
    def steps(self) -> float:
        """Pooled steps: mean convergence steps over every run (non-converged runs count their steps)."""
        all_steps = [r[1] for v in self.runs.values() for r in v]
        return float(np.mean(all_steps)) if all_steps else math.nan

    @property
    def geomean(self) -> float:
        """Geometric mean of the convergence steps over every run (non-converged runs count their steps)."""
        all_steps = [max(r[1], 1) for v in self.runs.values() for r in v]
        return float(np.exp(np.mean(np.log(all_steps)))) if all_steps else math.nan

    def score(self, objective: str) -> float:
        """What a search minimises: ``pooled`` steps or their ``geomean``."""
        return self.geomean if objective == "geomean" else self.steps

    @property
    def ratio(self) -> float:
        """Mean greedy path / A* over the converged runs."""
        vals = [r[2] for v in self.runs.values() for r in v if r[0]]
        return float(np.mean(vals)) if vals else math.inf

    @property
    def not_converged(self) -> int:
        return sum(1 for v in self.runs.values() for r in v if not r[0])

    def map_ratios(self) -> list[float]:
        """Per problem: mean greedy path / A* over its converged runs (``inf`` for a problem none converged on)."""
        return [float(np.mean(c)) if (c := [r[2] for r in v if r[0]]) else math.inf for v in self.runs.values()]

    def path_quality(self) -> dict[str, float]:
        """Greedy path / A* per problem (:meth:`map_ratios`): ``p95_map`` (numpy's linear interpolation; with a
        problem on which no run converged, an infinite ratio, the value at or above 95% of the problems) and
        ``worst_map`` over the problems; ``worst_run``: the longest single converged run."""
        m = self.map_ratios()
        runs = [r[2] for v in self.runs.values() for r in v if r[0]]
        finite = bool(m) and all(math.isfinite(x) for x in m)  # interpolation between infinities is undefined
        p95 = float(np.percentile(m, 95, method="linear" if finite else "higher")) if m else math.nan
        return {"p95_map": p95, "worst_map": max(m, default=math.nan),
                "worst_run": max(runs, default=math.nan)}

    def summary(self) -> dict[str, Any]:
        return {"steps": self.steps, "geomean": self.geomean, "ratio": self.ratio, "not_converged": self.not_converged,
                "runs": self.n_runs, "problems": len(self.runs), **self.path_quality()}


def chunks(problems: Sequence[Problem], size: int) -> list[list[Problem]]:
    """``problems`` in consecutive chunks of ``size`` (the last may be shorter)."""
    return [list(problems[i:i + size]) for i in range(0, len(problems), size)]


def evaluate(problems: Sequence[Problem], method: str, seeds: Sequence[int], ql: QLConfig, pc: PriorConfig,
             pool: Any = None, chunk: int = 0, after_chunk: Callable[[int, Evaluation], bool] | None = None,
             stop_on_failure: bool = False) -> tuple[Evaluation, str]:
    """Run ``method`` on every problem and seed; returns the evaluation and why it stopped early
    (``""``: it did not).

    ``pool``: a process pool (:func:`ndrql.workers.process_pool`) or ``None`` (this process).
    ``after_chunk(i, ev)`` is called after chunk ``i`` (of ``chunk`` problems; 0 = one chunk) with
    the runs so far; returning ``True`` stops the evaluation there (``"after_chunk"``). With
    ``stop_on_failure`` the evaluation stops (``"not converged"``) as soon as a run has not
    converged; which other runs finished by then may depend on the workers' timing, the decision does not.
    """
    from concurrent.futures import FIRST_COMPLETED, wait

    ev = Evaluation()
    for i, part in enumerate(chunks(problems, chunk or max(1, len(problems)))):
        if pool is None:
            for p in part:
                ev.add(p.key, run_problem(p, method, seeds, ql, pc, stop_on_failure))
                if stop_on_failure and ev.not_converged:
                    return ev, "not converged"
        else:
            pending = {pool.submit(run_problem, p, method, list(seeds), ql, pc, stop_on_failure): p for p in part}
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    ev.add(pending.pop(fut).key, fut.result())
                if stop_on_failure and ev.not_converged:
                    for fut in pending:
                        fut.cancel()
                    wait(pending)
                    return ev, "not converged"
            ev.runs = {p.key: ev.runs[p.key] for p in problems if p.key in ev.runs}  # problem order, not finish order
        if after_chunk is not None and after_chunk(i, ev):
            return ev, "after_chunk"
    return ev, ""


def tuning_problems(root: str | Path, samples: int, order_seed: int = 0, weights: str | None = None,
                    progress: bool = False) -> tuple[list[Problem], list[int], str]:
    """The first ``samples`` connected validation maps in the seeded order (module docstring),
    the skipped ids and the weights' digest."""
    ids = pick_samples(validation_ids(root), order_seed)
    return train_problems(root, ids, samples, weights, progress)
