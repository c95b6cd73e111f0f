"""``ndrql tune``'s search: an Optuna study per method, stored so that it resumes and can be shared.

- **Sampler**: TPE, seeded (:attr:`TuneConfig.seed`); with one process the same seed gives the
  same trials, so the same best trial.
- **Storage**: any Optuna storage URL, by default SQLite under the results directory. A killed
  search restarted with the same settings continues the same study: finished trials are kept, a
  trial that was running is failed after the heartbeat's grace period and retried once with the
  same constants. Several processes or machines may share one study through a common ``--storage``
  URL (Optuna's distributed mode); the trials then depend on timing.
- **Budget**: ``trials`` finished trials per study (completed or pruned), the SPEC point included
  as trial 0, the same for every method. With ``start_from``, trial 1 is that preset's constants for
  the method (e.g. a search on other maps), so the search starts from the best point known.
- **Objective**: pooled convergence steps, or their geometric mean (``objective``; for maps of many
  sizes and families, :mod:`ndrql.tuning.objective`), minimised, under three constraints (Optuna's
  constrained TPE): the mean greedy path / A* no worse than the SPEC constants', no more runs unconverged,
  and the worst map's greedy path / A* (mean over seeds) within :data:`~ndrql.tuning.objective.PATH_BOUND`.
  A run may take at most :attr:`TuneConfig.max_episodes` episodes; a trial with a run that does not
  converge within that is pruned on the spot (it breaks the second constraint). After each chunk of maps
  (from the ``prune_warmup``-th on) a trial is also pruned when it is hopeless: its running mean of
  steps is more than ``prune_factor`` times the best feasible trial's at the same point, or its
  running greedy path / A* is more than ``ratio_margin`` above the SPEC point's at the same point.
  (A median pruner does not fit a constrained search: fast trials with bad paths drag it down.)
- **Name**: the study's name holds the method and a digest of everything that defines the
  objective (maps, seeds, caps, search space), so changing any of them starts a new study.
"""

from __future__ import annotations

import json
import math
import sys
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

from ndrql.errors import NdrqlError
from ndrql.io import data_digest
from ndrql.tuning.shared import default_storage, engine_kwargs, retry_shared  # noqa: F401 (default_storage: re-exported)
from ndrql.planning import compiled
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.preset import load_preset
from ndrql.tuning import space as S
from ndrql.pipeline.samples import Problem
from ndrql.planning.methods import get_method
from ndrql.tuning.objective import PATH_BOUND, Evaluation, evaluate
from ndrql.workers import process_pool


#: What a search may minimise (:meth:`ndrql.tuning.objective.Evaluation.score`).
OBJECTIVES = ("pooled", "geomean")


@dataclass(frozen=True)
class TuneConfig:
    """Settings of one search (the CLI's flags)."""

    method: str
    """Method whose constants are searched (``ndrql.planning.methods``)."""
    trials: int = 200
    """Finished trials (completed or pruned) per study, the SPEC point included."""
    samples: int = 100
    """K: validation maps per evaluation."""
    seeds: int = 10
    """S: Q-learning seeds per map (``0 .. S-1``)."""
    seed: int = 0
    """Seed of the TPE sampler."""
    order_seed: int = 0
    """Seed of the order in which validation samples are drawn."""
    chunk: int = 10
    """Maps per pruning step (the running mean is reported after each chunk)."""
    max_episodes: int = 2000
    """Episode cap of a run during the search (the SPEC's 20,000 is kept everywhere else)."""
    startup_trials: int = 20
    """Random trials before TPE starts modelling (the SPEC point counts as one)."""
    prune_warmup: int = 3
    """Chunks a trial runs before it may be pruned as hopeless."""
    prune_factor: float = 1.5
    """Hopeless: running mean steps above this times the best feasible trial's at the same chunk."""
    ratio_margin: float = 0.03
    """Hopeless: running greedy path / A* this much above the SPEC point's at the same chunk."""
    heartbeat: int = 30
    """Seconds between a running trial's heartbeats (SQL storages)."""
    grace: int = 120
    """A running trial without a heartbeat for this long is failed and retried."""
    objective: str = "pooled"
    """What is minimised: ``pooled`` steps (the paper's measure) or their ``geomean`` (every map alike)."""
    start_from: str = ""
    """A preset (name or file) whose constants for the method are trial 1 (after the SPEC point); ``""``: none."""
    grid: int | None = None
    """Planning-grid size of the problems (``--maps generated``): which entry of a per-grid ``start_from`` preset
    trial 1 takes; ``None``: its smallest size's."""
    fixed: tuple[tuple[str, float], ...] = ()
    """Prior constants outside the search space held at these values in every trial and in what is exported
    (:data:`ndrql.tuning.space.FIXED_PRIORS`; the CLI takes them from ``start_from``); empty: the SPEC's."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "method", get_method(self.method).name)
        for name, low in (("trials", 1), ("samples", 1), ("seeds", 1), ("chunk", 1), ("max_episodes", 1),
                          ("startup_trials", 1), ("prune_warmup", 0), ("heartbeat", 1), ("grace", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < low:
                raise NdrqlError(f"{name.replace('_', '-')} must be an integer >= {low}, got {v!r}")
        if not (self.prune_factor >= 1.0 and self.ratio_margin >= 0.0):
            raise NdrqlError("prune_factor must be >= 1 and ratio_margin >= 0")
        if self.objective not in OBJECTIVES:
            raise NdrqlError(f"objective must be one of {', '.join(OBJECTIVES)}, got {self.objective!r}")
        unknown = [k for k, _ in self.fixed if k not in S.FIXED_PRIORS]
        if unknown:
            raise NdrqlError(f"{unknown[0]} is searched or not a constant; fixed constants: {', '.join(S.FIXED_PRIORS)}")
        try:
            PriorConfig(**dict(self.fixed))
        except ValueError as exc:
            raise NdrqlError(f"bad fixed constant: {exc}") from None
        if self.grace <= self.heartbeat:
            raise NdrqlError("the grace period must be longer than the heartbeat interval")

    @property
    def seed_list(self) -> list[int]:
        return list(range(self.seeds))

    def base_configs(self) -> tuple[QLConfig, PriorConfig]:
        """The SPEC constants with the search's episode cap and the :attr:`fixed` ones."""
        return QLConfig(max_episodes=self.max_episodes), PriorConfig(**dict(self.fixed))


def study_name(cfg: TuneConfig, problem_keys: Sequence[str], weights_digest: str | None) -> str:
    """``<method>-<digest>``: the digest covers everything that defines the objective."""
    parts = [S.SPACE_VERSION, cfg.method, list(problem_keys), cfg.seed_list, cfg.max_episodes, cfg.chunk,
             cfg.prune_warmup, cfg.prune_factor, cfg.ratio_margin, weights_digest, ["path bound", PATH_BOUND]]
    if cfg.objective != "pooled" or cfg.start_from:  # names of the studies searched before these existed stay valid
        parts += [cfg.objective, cfg.start_from]
    if cfg.fixed:  # likewise: a search without fixed constants keeps its name
        parts += [sorted(cfg.fixed)]
    blob = json.dumps(parts, sort_keys=True)
    return f"{cfg.method}-{data_digest(blob)[:10]}"


def open_storage(url: str, cfg: TuneConfig) -> Any:
    """An Optuna storage for ``url``; SQL ones with heartbeats, a stale trial retried once."""
    import optuna

    if not isinstance(url, str) or not url.startswith(("sqlite:", "postgresql", "mysql")):
        return url  # Optuna's own handling (and its error) for anything else
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # heartbeats and the retry callback are "experimental" in Optuna
        retry_cls = getattr(optuna.storages, "RetryHeartbeatStaleTrialCallback", None)
        kw: dict[str, Any] = {"heartbeat_interval": cfg.heartbeat, "grace_period": cfg.grace,
                              "engine_kwargs": engine_kwargs(url)}
        try:  # another tune process may be creating the same tables (ndrql.tuning.shared)
            if retry_cls is not None:
                return retry_shared(lambda: optuna.storages.RDBStorage(
                    url, heartbeat_stale_trial_callback=retry_cls(max_retry=1), **kw))
            retry = optuna.storages.RetryFailedTrialCallback(max_retry=1)
            return retry_shared(lambda: optuna.storages.RDBStorage(url, failed_trial_callback=retry, **kw))
        except Exception as exc:  # sqlalchemy's errors: a bad URL, a folder that does not exist
            raise NdrqlError(f"cannot open the study storage {url[:120]}: {exc.__class__.__name__}") from None


def fail_orphans(study: Any, grace: int) -> list[int]:
    """Fail the RUNNING trials that never recorded a heartbeat and started over ``grace`` s ago.

    Optuna fails stale trials only once they have a heartbeat; a process killed between creating a
    trial and its first heartbeat leaves the trial RUNNING for ever. Returns the failed numbers.
    """
    from datetime import datetime, timedelta

    from optuna.trial import TrialState

    storage = getattr(study._storage, "_backend", study._storage)  # under Optuna's cache wrapper
    models = _rdb_models()
    if models is None or not hasattr(storage, "scoped_session"):
        return []
    failed = []
    with storage.scoped_session() as session:
        beating = {tid for (tid,) in session.query(models.TrialHeartbeatModel.trial_id).all()}
    now = datetime.now()
    for t in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
        if t._trial_id in beating or t.datetime_start is None:
            continue
        if now - t.datetime_start > timedelta(seconds=grace):
            storage.set_trial_state_values(t._trial_id, TrialState.FAIL)
            failed.append(t.number)
    return failed


def _rdb_models() -> Any:
    try:
        from optuna.storages._rdb import models
    except ImportError:  # pragma: no cover - a future Optuna without this module: nothing to repair
        return None
    return models


def _has_set_constraint() -> bool:
    import optuna

    return hasattr(optuna.trial.Trial, "set_constraint")


#: A trial's constraints, each met at <= 0 (module docstring; a trial from before ``c_worst_map`` reads it as met).
CONSTRAINTS = ("c_ratio", "c_not_converged", "c_worst_map")


def _constraints_func(t: Any) -> list[float]:
    return [float(t.user_attrs.get(k, 0.0 if k == "c_worst_map" else math.inf)) for k in CONSTRAINTS]


def open_study(cfg: TuneConfig, name: str, storage: Any) -> Any:
    """Create or load the study ``name`` with the seeded TPE sampler and the median pruner."""
    import optuna

    sampler = optuna.samplers.TPESampler(
        seed=cfg.seed, n_startup_trials=cfg.startup_trials,
        constraints_func=None if _has_set_constraint() else _constraints_func)
    return retry_shared(lambda: optuna.create_study(study_name=name, storage=storage, sampler=sampler,  # shared
                                                    pruner=optuna.pruners.NopPruner(), direction="minimize",
                                                    load_if_exists=True))


def _constraint_values(ev: Evaluation, baseline: dict[str, Any]) -> dict[str, float]:
    ratio, worst = (x if math.isfinite(x) else 1e9 for x in (ev.ratio, ev.path_quality()["worst_map"]))
    return {"c_ratio": ratio - float(baseline["ratio"]), "c_worst_map": worst - PATH_BOUND,
            "c_not_converged": float(ev.not_converged - int(baseline["not_converged"]))}


def _set_constraints(trial: Any, values: dict[str, float]) -> None:
    for k, v in values.items():
        trial.set_user_attr(k, v)
        if _has_set_constraint():
            with warnings.catch_warnings():
                # a trial retried after a kill inherits the constraints its first attempt set (the same values:
                # the evaluation is seeded); Optuna keeps them and warns that the new ones are ignored
                warnings.filterwarnings("ignore", "The constraint value is ignored", UserWarning)
                trial.set_constraint(k, v)


def finished(study: Any) -> int:
    """Trials that count against the budget: completed or pruned."""
    from optuna.trial import TrialState

    return sum(1 for t in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE, TrialState.PRUNED)))


def _add_spec_trial(study: Any, cfg: TuneConfig, ev: Evaluation, running: list[float]) -> None:
    """Trial 0: the SPEC constants, evaluated once (it is also the constraints' reference)."""
    import optuna

    ql, pc = cfg.base_configs()
    params = S.params_of(cfg.method, ql, pc)
    attrs = {"spec": True, **{k: v for k, v in ev.summary().items()}, **dict.fromkeys(CONSTRAINTS, 0.0)}
    kw: dict[str, Any] = {"params": params, "distributions": S.distributions(cfg.method), "value": ev.score(cfg.objective),
                          "user_attrs": attrs, "intermediate_values": dict(enumerate(running))}
    if _has_set_constraint():
        kw["constraints"] = dict.fromkeys(CONSTRAINTS, 0.0)
    else:
        kw["system_attrs"] = {"constraints": [0.0] * len(CONSTRAINTS)}
    study.add_trial(optuna.trial.create_trial(**kw))


def baseline(study: Any, cfg: TuneConfig, problems: Sequence[Problem], pool: Any) -> dict[str, Any]:
    """The SPEC constants' evaluation, stored with the study (computed by the first process to need it)."""
    stored = study.user_attrs.get("baseline")
    if stored is not None:
        return stored
    ql, pc = cfg.base_configs()
    steps: list[float] = []
    ratios: list[float] = []

    def record(_i: int, ev: Evaluation) -> bool:
        steps.append(ev.score(cfg.objective))
        ratios.append(ev.ratio)
        return False

    ev, _ = evaluate(problems, cfg.method, cfg.seed_list, ql, pc, pool=pool, chunk=cfg.chunk, after_chunk=record)
    summary = {**ev.summary(), "running_ratio": ratios}
    study.set_user_attr("baseline", summary)
    study.set_user_attr("problems", [p.key for p in problems])
    study.set_user_attr("config", asdict(cfg))
    if not study.trials:
        _add_spec_trial(study, cfg, ev, steps)
    return summary


def make_objective(cfg: TuneConfig, problems: Sequence[Problem], base: dict[str, Any], pool: Any,
                   study: Any) -> Callable[[Any], float]:
    """The function Optuna minimises (module docstring)."""
    import optuna

    def objective(trial: Any) -> float:
        params = S.suggest(trial, cfg.method)
        ql, pc = S.configs_from_params(params, *cfg.base_configs())
        reason: list[str] = []
        best = best_trial(study)
        ref = dict(best.intermediate_values) if best is not None else {}
        base_ratio = base.get("running_ratio", [])

        def after_chunk(i: int, ev: Evaluation) -> bool:
            trial.report(ev.score(cfg.objective), i)
            if i + 1 < cfg.prune_warmup:
                return False
            if i in ref and ev.score(cfg.objective) > cfg.prune_factor * ref[i]:
                reason.append(f"steps over {cfg.prune_factor} x the best feasible trial's ({best.number}) after "
                              f"{i + 1} chunks")
                return True
            if i < len(base_ratio) and ev.ratio > base_ratio[i] + cfg.ratio_margin:
                reason.append(f"greedy path / A* over the spec point's + {cfg.ratio_margin} after {i + 1} chunks")
                return True
            return False

        ev, stopped = evaluate(problems, cfg.method, cfg.seed_list, ql, pc, pool=pool, chunk=cfg.chunk,
                               after_chunk=after_chunk, stop_on_failure=int(base["not_converged"]) == 0)
        if stopped == "not converged":
            # Infeasible whatever else happens; the recorded values must not depend on which other
            # runs the workers had finished, so the constraints are fixed and nothing is reported.
            trial.set_user_attr("pruned_because", f"a run did not converge within {cfg.max_episodes} episodes")
            _set_constraints(trial, {"c_ratio": 0.0, "c_not_converged": 1.0, "c_worst_map": 0.0})
            raise optuna.TrialPruned("a run did not converge")
        for k, v in ev.summary().items():
            trial.set_user_attr(k, v)
        _set_constraints(trial, _constraint_values(ev, base))
        if stopped:
            trial.set_user_attr("pruned_because", reason[0])
            raise optuna.TrialPruned(reason[0])
        return ev.score(cfg.objective)

    return objective


def start_params(cfg: TuneConfig) -> dict[str, float]:
    """The searched constants of ``cfg.method`` in preset ``cfg.start_from``, clipped into the search space."""
    ql, pc = load_preset(cfg.start_from).configs(cfg.method, grid=cfg.grid)
    params = S.params_of(cfg.method, ql, pc)
    bounds = {p.name: (p.low, p.high) for p in S.search_space(cfg.method)}
    return {k: min(max(v, bounds[k][0]), bounds[k][1]) for k, v in params.items()}


def base_score(base: dict[str, Any], cfg: TuneConfig) -> float:
    """The SPEC point's value of the search's objective (an old baseline without a geomean: its pooled steps)."""
    return float(base.get("geomean", base["steps"]) if cfg.objective == "geomean" else base["steps"])


def best_trials(study: Any, k: int) -> list[Any]:
    """The ``k`` completed feasible trials with the fewest steps, best first (ties: the earliest)."""
    from optuna.trial import TrialState

    ok = [t for t in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))
          if t.value is not None and all(v <= 0 for v in _constraints_func(t))]
    return sorted(ok, key=lambda t: (t.value, t.number))[:k]


def best_trial(study: Any) -> Any:
    """The completed feasible trial with the fewest steps (ties: the earliest); ``None`` if none."""
    return next(iter(best_trials(study, 1)), None)


def run_study(cfg: TuneConfig, problems: Sequence[Problem], storage: str, weights_digest: str | None = None,
              workers: int = 1, progress: bool = True, name: str | None = None) -> Any:
    """Run (or continue) the study of ``cfg.method`` on ``problems`` until it has ``cfg.trials``
    finished trials; returns the Optuna study. ``workers`` processes run each trial's maps."""
    import optuna
    from tqdm import tqdm

    if not problems:
        raise NdrqlError("no planning problems to tune on")
    optuna.logging.set_verbosity(optuna.logging.ERROR)  # a failed trial propagates: ndrql's one line says it
    name = name or study_name(cfg, [p.key for p in problems], weights_digest)
    study = open_study(cfg, name, open_storage(storage, cfg))
    fail_orphans(study, cfg.grace)
    compiled.warm_up()  # compile once before forking workers
    pool = process_pool(workers, start_method="fork") if workers > 1 else None
    try:
        base = baseline(study, cfg, problems, pool)
        if cfg.start_from and len(study.trials) == 1:
            study.enqueue_trial(start_params(cfg), skip_if_exists=True)
        objective = make_objective(cfg, problems, base, pool, study)
        done = finished(study)
        bar = tqdm(total=cfg.trials, initial=min(done, cfg.trials), desc=f"tune {cfg.method}", unit="trial",
                   disable=not progress, file=sys.stderr, dynamic_ncols=True)

        def show_best(st: Any, _t: Any) -> None:
            bt = best_trial(st)
            bar.n = min(finished(st), cfg.trials)
            if bt is not None:
                bar.set_postfix_str(f"best {bt.value:,.0f} steps (trial {bt.number}; spec {base_score(base, cfg):,.0f})",
                                    refresh=False)
            bar.refresh()

        try:
            while finished(study) < cfg.trials:
                study.optimize(objective, n_trials=1, callbacks=[show_best], catch=())
        finally:
            bar.close()
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    return study
