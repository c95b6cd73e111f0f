"""Which constants of a method without the model's priors (QL, O-QL, IQL) keep the worst map of the tuning
set within the path bound (``ndrql.tuning.report.PATH_BOUND``), and at what cost in steps?

Each candidate runs on the problems of the preset's search at one grid (the ``tune`` set, the same 120 maps
in the same order) with the preset's check seeds: geometric mean of the steps, greedy path / A* mean, its
95th percentile over maps and the worst map. Candidates: the spec constants, the preset's entries for every
grid, and the best trial of each study given (``--study FILE``; a study's bounded best: its best trial
whose own mean path ratio is within the bound is not known to the study, so every trial in the top
``--top`` by steps is tried).

    PYTHONPATH=src python studies/path_candidates.py --method IQL --grid 50 --study results/tune-evidence/IQL-g50-s1/studies.db
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace

import numpy as np

from ndrql.experiments.ceiling import case_problem, grid_case, larger_sizes
from ndrql.experiments.eval_sets import eval_set, tuning_spec
from ndrql.pipeline.samples import Problem
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.preset import load_preset
from ndrql.tuning import space as S
from ndrql.tuning.objective import evaluate


def problems(keys: list[str], n: int) -> list[Problem]:
    """The search's problems (keys ``tune-g<n>-<i>``) without the model's priors."""
    gs = eval_set(tuning_spec("tune"), progress=False)
    out = []
    for key in keys:
        i = int(key.rsplit("-", 1)[1])
        raw = gs.raw(i)
        c = grid_case(key, str(gs.families[i]), raw.obstacles, raw.start, raw.goal, n, larger_sizes(n))
        out.append(case_problem(c, f"tune-g{n}", i))
    return out


def study_tops(db: str, method: str, top: int) -> list[tuple[str, dict]]:
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    url = f"sqlite:///{db}"
    name = [s.study_name for s in optuna.get_all_study_summaries(url) if s.study_name.startswith(method + "-")][0]
    trials = [t for t in optuna.load_study(study_name=name, storage=url).trials if t.value is not None]
    return [(f"{name} trial {t.number}", dict(t.params)) for t in sorted(trials, key=lambda t: t.value)[:top]]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--method", required=True, choices=("QL", "O-QL", "IQL"))
    ap.add_argument("--grid", type=int, required=True)
    ap.add_argument("--preset", default="general")
    ap.add_argument("--study", action="append", default=[])
    ap.add_argument("--top", type=int, default=5)
    ap.add_argument("--also", action="append", default=[], help="another preset whose entry for the method is a candidate")
    ap.add_argument("--epsilons", default="", help="also the preset's entry for --grid with each of these epsilons "
                    "(comma-separated): how much exploration keeps the worst map within the bound")
    ap.add_argument("--scan", default="", help="also the preset's entry for --grid with D-CRF's r_max and G set to "
                    "each pair of these lists, e.g. 'r_max=5,10,20;G=10,20,46' (a grid scan under the bound)")
    ap.add_argument("--no-spec", action="store_true", help="leave the spec constants out (slow for QL)")
    ap.add_argument("--out")
    args = ap.parse_args(argv)
    preset = load_preset(args.preset)
    meta = preset.meta["grids"][str(args.grid)]
    probs = problems(meta["search"]["problems"], args.grid)
    seeds = meta["check_seeds"]
    cands = [] if args.no_spec else [("spec", QLConfig(), PriorConfig())]
    cands += [(f"{args.preset} grid {n}", *preset.configs(args.method, grid=n)) for n in sorted(preset.grids)]
    cands += [(name, *load_preset(name).configs(args.method, grid=args.grid)) for name in args.also]
    base_ql, base_pc = preset.configs(args.method, grid=args.grid)
    cands += [(f"{args.preset} grid {args.grid}, epsilon {e}", replace(base_ql, epsilon=float(e)), base_pc)
              for e in args.epsilons.split(",") if e.strip()]
    if args.scan:
        lists = dict(part.split("=") for part in args.scan.split(";"))
        for r in lists["r_max"].split(","):
            for g in lists["G"].split(","):
                cands.append((f"{args.preset} grid {args.grid}, r_max {r}, G {g}", base_ql,
                              replace(base_pc, r_max=float(r), g_row=float(g), g_col=float(g))))
    for db in args.study:
        for label, params in study_tops(db, args.method, args.top):
            cands.append((label, *S.configs_from_params(params)))
    rows = []
    for label, ql, pc in cands:
        ev, _ = evaluate(probs, args.method, seeds, ql, pc)
        s = ev.summary()
        row = {"candidate": label, "geomean": s["geomean"], "mean": s["ratio"], "p95_map": s["p95_map"],
               "worst_map": s["worst_map"], "worst_run": s["worst_run"], "not_converged": s["not_converged"],
               "runs": s["runs"],
               "ql": vars(ql), "priors": {k: getattr(pc, k) for k in ("r_max", "g_row", "g_col")}}
        rows.append(row)
        print(f"{label}: geomean {s['geomean']:,.0f}, path mean {s['ratio']:.3f}, p95 {s['p95_map']:.3f}, "
              f"worst {s['worst_map']:.3f}, not converged {s['not_converged']}", flush=True)
    if args.out:
        with open(args.out, "w") as fh:
            json.dump(rows, fh, indent=1, default=float)
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    raise SystemExit(main())
