"""Adopt a re-searched method's constants or not: the shipped preset's against a study's best trial on ``select``.

A search on ``tune`` picks the best of many noisy trials, so its figure flatters it; the check runs both
sets of constants on the ``select`` set (another development set, never searched on) with fresh seeds,
on the planning grid ``transfer`` and ``plan`` build (the safe grid of ``--grid`` cells, or the next auto
size that connects), and prints the geometric mean ratio of the steps with its bootstrap interval, clear
wins / ties / losses (a test over seeds) and the greedy path / A* (mean, 95th percentile, worst map).
Methods without the model's priors only (QL, O-QL, IQL).

    PYTHONPATH=src python studies/adoption_check.py --method IQL --grid 50 \\
        --study results/tune-evidence/IQL-g50-s1/studies.db --seeds 10
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from ndrql.experiments.ceiling import grid_case, larger_sizes
from ndrql.experiments.eval_sets import eval_set, eval_spec
from ndrql.experiments.stats import geomean_ratio, outcomes
from ndrql.planning.preset import load_preset
from ndrql.planning.runner import run_plan
from ndrql.tuning import space as S


def best_constants(db: str, method: str):
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    url = f"sqlite:///{db}"
    (summary,) = [s for s in optuna.get_all_study_summaries(url) if s.study_name.startswith(method + "-")]
    study = optuna.load_study(study_name=summary.study_name, storage=url)
    best = study.best_trial
    return summary.study_name, len(study.trials), best.number, best.value, dict(best.params)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--method", required=True, choices=("QL", "O-QL", "IQL"))
    ap.add_argument("--grid", type=int, required=True)
    ap.add_argument("--study", help="the search's sqlite file: its best trial is the candidate")
    ap.add_argument("--set-priors", default="", help="instead of a study: the preset's entry with these prior "
                    "constants, e.g. 'r_max=5,G=10' (G sets g_row and g_col)")
    ap.add_argument("--preset", default="general")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--seed0", type=int, default=100, help="first seed (fresh: the searches used 0..4, their checks 5..9)")
    ap.add_argument("--out", help="write the figures as JSON here")
    args = ap.parse_args(argv)
    preset = load_preset(args.preset)
    ql0, pc0 = preset.configs(args.method, grid=args.grid)
    if args.study:
        name, trials, number, value, params = best_constants(args.study, args.method)
    else:
        params = {k: float(v) for k, v in (kv.split("=") for kv in args.set_priors.split(","))}
        name, trials, number, value = f"{args.preset} grid {args.grid} with {args.set_priors}", 0, None, None
    ql1, pc1 = S.configs_from_params(params, ql0, pc0)
    gs = eval_set(eval_spec("select"), progress=False)
    seeds = list(range(args.seed0, args.seed0 + args.seeds))
    a, b, pa, pb = [], [], [], []
    for i in range(len(gs)):
        raw = gs.raw(i)
        c = grid_case(f"select-{i}", str(gs.families[i]), raw.obstacles, raw.start, raw.goal, args.grid,
                      larger_sizes(args.grid))
        if c is None:
            continue
        for out, paths, (q, p) in ((a, pa, (ql0, pc0)), (b, pb, (ql1, pc1))):
            runs = [run_plan(c.blocked, c.start_cell, c.goal_cell, args.method, s, q, p) for s in seeds]
            out.append([r.convergence_steps if r.converged else r.total_steps for r in runs])
            paths.append(float(np.mean([r.length_ratio for r in runs if r.converged] or [np.inf])))
    means = lambda x: [float(np.mean(v)) for v in x]  # noqa: E731
    res = {"study": name, "trials": trials, "best_trial": number, "best_value_on_tune": value, "params": params,
           "maps": len(a), "seeds": seeds, "preset": args.preset, "grid": args.grid,
           "candidate_vs_preset": geomean_ratio(means(b), means(a)), "outcomes": outcomes(b, a),
           "path_preset": {"mean": float(np.mean(pa)), "p95": float(np.percentile(pa, 95)), "worst": float(np.max(pa))},
           "path_candidate": {"mean": float(np.mean(pb)), "p95": float(np.percentile(pb, 95)), "worst": float(np.max(pb))},
           "geomean_preset": float(np.exp(np.mean(np.log(means(a))))),
           "geomean_candidate": float(np.exp(np.mean(np.log(means(b)))))}
    print(json.dumps(res, indent=1))
    if args.out:
        with open(args.out, "w") as fh:
            json.dump(res, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
