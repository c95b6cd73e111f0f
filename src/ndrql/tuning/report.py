"""What a finished search leaves behind: per-method outputs, figures and the ``tuned`` preset.

- :func:`write_study_outputs`: ``<out>/<method>/best.json`` (best feasible trial and the SPEC
  point), ``trials.json`` (every trial), ``history.png`` and ``importance.png`` (Optuna's own
  optimisation-history and parameter-importance plots, matplotlib backend).
- :func:`check_presets`: the SPEC constants against the tuned ones on the same validation maps
  with *fresh* seeds (not the ones the search saw) and the SPEC's full 20,000-episode budget, so
  the comparison is not biased by selecting the best of many noisy trials.
- :func:`tuned_preset`: the preset of the best trials that won that check (fewer pooled steps,
  greedy path / A* not significantly worse, no more runs without convergence); a method whose best
  trial did not win keeps the SPEC constants.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from typing import Any, Sequence

from ndrql.io import make_folder, save_figure, write_json
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.preset import MethodSetting, Preset, configs_dict
from ndrql.tuning import space as S
from ndrql.pipeline.samples import Problem
from ndrql.tuning.objective import PATH_BOUND, Evaluation, evaluate
from ndrql.tuning.study import TuneConfig, base_score, best_trial


def trial_rows(study: Any) -> list[dict[str, Any]]:
    """Every trial: number, state, value, params, the evaluation's numbers and constraints."""
    rows = []
    for t in study.get_trials(deepcopy=False):
        rows.append({"number": t.number, "state": t.state.name, "value": t.value, "params": dict(t.params),
                     "user_attrs": dict(t.user_attrs)})
    return rows


def best_setting(study: Any, method: str, fixed: PriorConfig = PriorConfig()) -> tuple[MethodSetting, Any]:
    """The best feasible trial's constants as a :class:`MethodSetting` (SPEC if no trial beat it), on top of
    ``fixed`` (the search's constants outside its space, :attr:`~ndrql.tuning.study.TuneConfig.fixed`)."""
    bt = best_trial(study)
    return trial_setting(bt, fixed), bt


def trial_setting(trial: Any, fixed: PriorConfig = PriorConfig()) -> MethodSetting:
    """A trial's constants (the SPEC's for ``None``) on top of ``fixed``."""
    ql, pc = S.configs_from_params(dict(trial.params) if trial is not None else {}, QLConfig(), fixed)
    return MethodSetting(ql, pc)


def objective_label(cfg: TuneConfig) -> str:
    """The objective in words, for plots and reports."""
    return "geometric mean of convergence steps" if cfg.objective == "geomean" else "pooled convergence steps"


def write_study_outputs(study: Any, cfg: TuneConfig, out_dir: str | Path) -> Path:
    """Write the method's best trial, all trials and Optuna's two plots; returns the folder."""
    import warnings

    folder = make_folder(Path(out_dir) / cfg.method)
    setting, bt = best_setting(study, cfg.method, cfg.base_configs()[1])
    base = study.user_attrs.get("baseline", {})
    from optuna.trial import TrialState

    states = [t.state for t in study.get_trials(deepcopy=False)]
    write_json(folder / "best.json", {
        "method": cfg.method, "study": study.study_name, "config": study.user_attrs.get("config"),
        "problems": study.user_attrs.get("problems"), "baseline_spec": base,
        "best_trial": None if bt is None else {"number": bt.number, "value": bt.value, "params": bt.params,
                                                "user_attrs": dict(bt.user_attrs)},
        "best_constants": configs_dict(setting.ql, setting.priors),
        "objective": cfg.objective,
        "improvement_over_spec": None if bt is None or not base else 1.0 - bt.value / base_score(base, cfg),
        "trials": {s.name: sum(1 for x in states if x == s) for s in TrialState},
    }, strict=False)
    write_json(folder / "trials.json", trial_rows(study), indent=None, strict=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Optuna marks its matplotlib plots "experimental"
        from optuna.visualization.matplotlib import plot_optimization_history, plot_param_importances

        ax = plot_optimization_history(study, target_name=objective_label(cfg))
        ax.set_title("", loc="left")  # Optuna's own title
        ax.set_title(f"{cfg.method}: optimisation history ({len(states)} trials; grey: infeasible)")
        ax.set_yscale("log")
        save_figure(ax.figure, folder / "history.png", dpi=110, bbox_inches="tight")
        if len(S.search_space(cfg.method)) > 1 and sum(1 for s in states if s == TrialState.COMPLETE) > 2:
            ax = plot_param_importances(study, target_name=objective_label(cfg))
            ax.set_title("", loc="left")
            ax.set_title(f"{cfg.method}: parameter importance")
            save_figure(ax.figure, folder / "importance.png", dpi=110, bbox_inches="tight")
    import matplotlib.pyplot as plt

    plt.close("all")
    return folder


def paired_ratio_difference(spec: Evaluation, tuned: Evaluation) -> tuple[float, float, int]:
    """Mean and standard error of tuned - spec greedy path / A* over the runs (same map and seed)
    where both converged, and how many such pairs there are."""
    diffs = [b[2] - a[2] for k in spec.runs for a, b in zip(spec.runs[k], tuned.runs.get(k, [])) if a[0] and b[0]]
    if not diffs:
        return math.nan, math.nan, 0
    d = np.asarray(diffs, dtype=np.float64)
    se = float(d.std(ddof=1) / math.sqrt(d.size)) if d.size > 1 else math.inf
    return float(d.mean()), se, int(d.size)


def path_verdict(record: dict, preset: Preset | None = None) -> list[str]:
    """What exceeds :data:`PATH_BOUND` in a preset's ``path_quality`` record (one line each; empty: none).
    With ``preset``, entries that hold the paper's constants (spec) are exempt (:data:`PATH_BOUND`)."""
    out = []
    for n, methods in record["grids"].items():
        for m, q in methods.items():
            spec = preset is not None and preset.configs(m, grid=int(n) if preset.grids else None) == \
                (QLConfig(), PriorConfig())
            if not spec and not q["worst_map"] <= PATH_BOUND:
                out.append(f"grid {n} {m}: worst map {q['worst_map']:.3f} > {PATH_BOUND}")
    return out


def check_presets(problems: Sequence[Problem], methods: Sequence[str], settings: dict[str, MethodSetting],
                  seeds: Sequence[int], pool: Any = None, objective: str = "pooled",
                  alternates: dict[str, Sequence[MethodSetting]] | None = None) -> dict[str, dict[str, Any]]:
    """SPEC vs tuned constants per method on ``problems`` x ``seeds`` (full SPEC episode budget).

    The tuned constants win when they take fewer steps (by the search's ``objective``: pooled, or
    their geometric mean), leave no more runs unconverged, and
    their greedy path / A* is not significantly worse: the paired mean difference (same map and
    seed) is at most 1.96 standard errors above 0. (Read strictly, "no worse" would reject a set of
    constants for a difference far inside the seed noise and keep a weaker baseline.) And on the worst
    map of ``problems`` their path is within :data:`PATH_BOUND` of the optimum.

    ``alternates[m]``: the search's next-best constants for ``m``, best first. When ``settings[m]`` does
    not win, each is checked in turn (against the same SPEC runs) until one wins; ``candidate`` in the
    result is the index of the constants judged last (0: ``settings[m]``) and ``candidates_checked``
    how many were run. Checking several against the same fresh seeds selects on them a little: the
    adopted constants are still to be checked on another set (``studies/adoption_check.py``).
    """
    out = {}
    key = "geomean" if objective == "geomean" else "steps"
    for m in methods:
        spec_ev, _ = evaluate(problems, m, seeds, QLConfig(), PriorConfig(), pool=pool)
        a = spec_ev.summary()
        for i, s in enumerate([settings[m], *(alternates or {}).get(m, ())]):
            tuned_ev, _ = evaluate(problems, m, seeds, s.ql, s.priors, pool=pool)
            b = tuned_ev.summary()
            diff, se, pairs = paired_ratio_difference(spec_ev, tuned_ev)
            wins = (b[key] < a[key] and b["not_converged"] <= a["not_converged"]
                    and (pairs == 0 or diff <= 1.96 * se) and b["worst_map"] <= PATH_BOUND)
            out[m] = {"spec": a, "tuned": b, "improvement": 1.0 - b[key] / a[key], "objective": objective,
                      "ratio_difference": {"mean": diff, "se": se, "pairs": pairs}, "tuned_wins": bool(wins),
                      "candidate": i, "candidates_checked": i + 1}
            if wins:
                break
    return out


def tuned_preset(settings: dict[str, MethodSetting], check: dict[str, dict[str, Any]], meta: dict[str, Any],
                 fallback: str | None = None) -> Preset:
    """The ``tuned`` preset (module docstring): per method the searched constants if they won the
    check on fresh seeds, else the SPEC constants (listed in ``meta["kept_spec"]``); a method not
    searched gets the SPEC constants too, unless ``fallback`` names a searched method to use instead;
    ``plan_default`` when NDR-QL's searched constants won (``ndrql plan``'s default method), or,
    without NDR-QL, when every method's did."""
    methods = {m: (s if check.get(m, {}).get("tuned_wins") else MethodSetting()) for m, s in settings.items()}
    kept = [m for m in settings if not check.get(m, {}).get("tuned_wins")]
    wins = check["NDR-QL"]["tuned_wins"] if "NDR-QL" in check else (bool(check) and not kept)
    return Preset(name="tuned", methods=methods, fallback=fallback if fallback in methods else None,
                  plan_default=bool(wins), meta={**meta, "validation_check": check, "kept_spec": kept})


def improvement(a: float | None, b: float | None) -> float | None:
    """``1 - a / b`` (fewer steps = positive), ``None`` when undefined."""
    if a is None or b is None or not b or not math.isfinite(a) or not math.isfinite(b):
        return None
    return 1.0 - a / b
