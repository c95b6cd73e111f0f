"""Methods and seeds of a plan, each method's priors on the planning grid, and the Q-learning runs."""

from __future__ import annotations

import itertools
import sys
import warnings
from typing import Callable, Sequence

import numpy as np

from ndrql.errors import NdrqlError, brief
from ndrql.limits import BOUNDS, MAX_RUNS, check_bound, check_seeds
from ndrql.maps.grid import PlanningGrid
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import Method, Priors, build_priors, get_method
from ndrql.planning.results import PlanResult
from ndrql.planning.runner import PlanJob, default_workers, run_many, run_plan

#: A method's constants by name: ``name -> (QLConfig, PriorConfig)``.
Constants = Callable[[str], tuple[QLConfig, PriorConfig]]


def methods_named(methods: Sequence[str | Method] | str) -> list[Method]:
    """The methods to run, each once; :class:`NdrqlError` for none, an unknown name or a repeated one."""
    names = [methods] if isinstance(methods, (str, Method)) else list(methods) if isinstance(methods, (list, tuple)) \
        else None
    if names is None or not all(isinstance(n, (str, Method)) for n in names):
        raise NdrqlError(f"methods must be a method name or a list of them, got {brief(methods)}")
    ms = [get_method(n.strip() if isinstance(n, str) else n) for n in names]
    if not ms:
        raise NdrqlError("no method given")
    if len({m.name for m in ms}) != len(ms):
        raise NdrqlError(f"a method is listed twice: {', '.join(m.name for m in ms)}")
    return ms


def seeds_given(seeds: Sequence[int] | int) -> list[int]:
    """A list of seeds, or ``N`` for ``0..N-1``; :class:`NdrqlError` for none, ``ValueError`` beyond the CLI's
    bounds (at most :data:`ndrql.limits.MAX_RUNS` seeds, each an integer in ``0 .. 2**63 - 1``)."""
    if isinstance(seeds, (int, np.integer)) and not isinstance(seeds, bool):
        if int(seeds) < 1:
            raise NdrqlError("no seed given")
        return list(check_seeds(0, int(seeds), "seed", "seeds"))
    out = list(itertools.islice(seeds, MAX_RUNS + 1))
    if not out:
        raise NdrqlError("no seed given")
    if len(out) > MAX_RUNS:
        raise ValueError(f"seeds: at most {MAX_RUNS:,} seeds per call")
    return [int(check_seeds(s.item() if isinstance(s, np.integer) else s, 1, "each seed")[0]) for s in out]


def method_priors(ms: Sequence[Method], grid: PlanningGrid, region: np.ndarray | None, guideline: np.ndarray | None,
                  consts: Constants, distance: np.ndarray | None = None, threshold: float | None = ...,  # type: ignore[assignment]
                  ) -> tuple[dict[str, Priors], dict[str, float | None]]:
    """Each method's priors (Eqs. 2-7) and the NDR-QI threshold (Eq. 7) of those that use it; ``distance``:
    the model's goal distance for Eq. 6 (``None``: the straight line); ``threshold``: Eq. 7's threshold as the
    judge found it (:func:`ndrql.pipeline.judge.judge`; left out, each NDR-QI searches its own)."""
    priors: dict[str, Priors] = {}
    thresholds: dict[str, float | None] = {}
    for m in ms:
        priors[m.name] = build_priors(m, grid.blocked, grid.start, grid.goal, region, guideline, consts(m.name)[1],
                                      distance, threshold)
        if m.n_qi:
            thresholds[m.name] = priors[m.name].threshold
    return priors, thresholds


def qi_distance(ms: Sequence[Method], consts: Constants, thresholds: dict[str, float | None], base: str) -> str:
    """What Eq. 6's distance was (``plan --json``'s ``qi_distance``): ``base`` (``model`` or ``straight line``), or
    the moves through the region for the methods whose constants ask for it and whose region has a threshold
    (:func:`ndrql.planning.priors.region_distance`), ``base`` elsewhere."""
    through = [m.name for m in ms
               if m.n_qi and consts(m.name)[1].region_distance and thresholds.get(m.name) is not None]
    return f"moves through the region ({', '.join(through)}), the {base} elsewhere" if through else base


def check_workers(workers: int | None) -> int:
    """Worker processes for the runs (default: all cores); :class:`NdrqlError` below 1."""
    if workers is None:
        return default_workers()
    return int(check_bound(workers, BOUNDS["--workers"], "workers"))  # the one table (ndrql.limits)


def learn(grid: PlanningGrid, ms: Sequence[Method], seeds: Sequence[int], consts: Constants,
          priors: dict[str, Priors], region: np.ndarray | None, guideline: np.ndarray | None, workers: int,
          keep_records: bool = False, progress: bool = False, distance: np.ndarray | None = None,
          threshold: float | None = ...) -> list[PlanResult]:  # type: ignore[assignment]
    """Every method with every seed (methods outer): in this process with the given priors, or on
    ``workers`` processes (:func:`~ndrql.planning.runner.run_many`, which rebuilds the same priors from
    ``region``, ``guideline``, ``distance`` and the judged ``threshold``)."""
    jobs = [(m, s) for m in ms for s in seeds]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # NDR-QI warnings were raised once while building priors
        if workers == 1 or len(jobs) == 1:
            shown = jobs
            if progress and sys.stderr.isatty():  # tqdm only when its bar shows (importing it costs ~25-50 ms)
                from tqdm import tqdm  # progress: a bar of finished runs on stderr, on a terminal only

                shown = tqdm(jobs, desc="runs", unit="run", leave=False)
            return [run_plan(grid.blocked, grid.start, grid.goal, m.name, s, *consts(m.name), priors=priors[m.name],
                             keep_records=keep_records)
                    for m, s in shown]
        return run_many([PlanJob(grid.blocked, grid.start, grid.goal, m.name, s, *consts(m.name), region, guideline,
                                 keep_records, distance, threshold) for m, s in jobs], workers=workers, progress=progress)
