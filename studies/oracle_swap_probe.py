"""Which of the model's three outputs holds NDR-QL back? Swap one at a time for the oracle's.

NDR-QL takes three arrays from the model on the planning grid: the region (Eq. 6's mask via the
Eq. 7 threshold), the guideline (Eq. 3's rewards) and, beyond the paper, the goal distance (Eq. 6's
distance term). The oracle gives the perfect version of each (the grid's own shortest path drawn
like the labels; the exact 4-connected moves to the goal). This probe runs NDR-QL with every
combination where exactly one output is the oracle's (and all or none), same constants (the preset's
NDR-QL for the grid each map is planned on), same seeds, and reports how often each beats IQL: the
gain of a row over the model's is what a perfect version of that one output would be worth.

A diagnostic for where to train next, run on ``select`` (never on the reported set):

    python studies/oracle_swap_probe.py --grid 50            # 20 maps per family, 10 seeds (~4 min)
    python studies/oracle_swap_probe.py --grid 50 --rows model --weights FILE   # a candidate's own row
"""

from __future__ import annotations

import math

import numpy as np

from ndrql.experiments.ceiling import oracle_priors
from ndrql.experiments.transfer import row_configs
from ndrql.model.predict import Predictor
from ndrql.model.symmetry import DEFAULT_COUNT
from ndrql.model.weights import resolve_weights
from win_share_search import cases_of, probe_parser, probe_preset, reference_runs, runs

#: Rows: which outputs come from the oracle (region, guideline, distance).
SWAPS = {
    "model": (False, False, False),
    "oracle region": (True, False, False),
    "oracle guideline": (False, True, False),
    "oracle distance": (False, False, True),
    "oracle (all three)": (True, True, True),
}


def mixed(model: list[np.ndarray], oracle: tuple[np.ndarray, ...], take: tuple[bool, bool, bool]) -> list[np.ndarray]:
    """The model's arrays with those flagged in ``take`` replaced by the oracle's."""
    return [np.asarray(o if t else m) for m, o, t in zip(model, oracle, take)]


def main() -> None:
    ap = probe_parser(__doc__, symmetries=DEFAULT_COUNT)
    ap.add_argument("--rows", default=",".join(SWAPS), help=f"rows to run, comma-separated (default all: {', '.join(SWAPS)})")
    args = ap.parse_args()
    rows = [r.strip() for r in args.rows.split(",") if r.strip()]
    unknown = [r for r in rows if r not in SWAPS]
    if unknown:
        raise SystemExit(f"unknown row(s) {', '.join(unknown)}; valid: {', '.join(SWAPS)}")

    predictor = Predictor.load(resolve_weights(args.weights), threads=1, backend="torch", symmetries=args.symmetries)
    preset = probe_preset(args)
    cases = cases_of(args.set, args.grid, args.per_family, predictor)
    if any(len(pr) < 3 for _, _, pr in cases):
        raise SystemExit(f"{args.weights} has no distance head: nothing to swap for the oracle's distance")
    seeds = list(range(args.seeds))
    ref = reference_runs(cases, preset, seeds)
    ql_runs = [runs(c, "QL", *row_configs(preset, grid=c.n)["QL"], None, seeds) for _, c, _ in cases]
    ql_total = sum(r[:, 0].sum() for r in ql_runs)
    oracles = [oracle_priors(c, distance=True) for _, c, _ in cases]
    print(f"{args.set}, grid {args.grid}: {len(cases)} maps x {len(seeds)} seeds, weights {args.weights}, "
          f"preset {args.preset}, {args.symmetries} orientations")
    print("| NDR-QL with | beats IQL | maps won | geometric mean of steps | vs QL pooled | path / A* |")
    print("|---|---:|---:|---:|---:|---:|")
    for name in rows:
        take = SWAPS[name]
        won, logs, total, ratios = 0, [], 0.0, []
        for (fam, case, pr), orc, iq in zip(cases, oracles, ref):
            q, p = row_configs(preset, grid=case.n)["NDR-QL (model)"]
            st = runs(case, "NDR-QL", q, p, mixed(pr, orc, take), seeds)
            won += int(st[:, 0].mean() < iq[:, 0].mean())
            logs.append(math.log(st[:, 0].mean()))
            total += st[:, 0].sum()
            ratios.extend(x for x in st[:, 1] if not math.isnan(x))
        print(f"| {name} | {100 * won / len(cases):.1f}% | {won} of {len(cases)} | {math.exp(np.mean(logs)):,.0f} | "
              f"{100 * (total / ql_total - 1):+.1f}% | {np.mean(ratios):.3f} |", flush=True)


if __name__ == "__main__":
    main()
