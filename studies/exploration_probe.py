"""How much of "beats IQL" is exploration? NDR-QL against IQL with both exploration rates scaled.

On many maps both NDR-QL and IQL follow a shortest route from the first episode and converge in the
fewest episodes the rule allows (W), so both need about W times its length in steps; which of the
two is lower is then decided by a few epsilon-greedy moves and by any wrong move of the prior on the
route in the first episode. This probe runs both methods on ``select`` (never the reported set) with
the preset's constants but each one's epsilon multiplied by every factor of ``--scales``, and prints
for every pair of factors how many maps NDR-QL wins, ties (mean steps within ``--tie`` of IQL's, the
transfer report's :func:`~ndrql.experiments.transfer_report.against_iql`) and loses by more:

    python studies/exploration_probe.py --grid 50 --scales 1,0.5,0.25,0.1,0.01   # ~2 min
    python studies/exploration_probe.py --grid 100 --scales 1,0.01               # ~6 min
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ndrql.experiments.stats import TIE
from ndrql.experiments.transfer import row_configs
from ndrql.experiments.transfer_report import against_iql
from ndrql.model.predict import Predictor
from ndrql.model.symmetry import DEFAULT_COUNT
from ndrql.model.weights import resolve_weights
from win_share_search import cases_of, probe_parser, probe_preset, runs


def main() -> None:
    ap = probe_parser(__doc__, symmetries=DEFAULT_COUNT)
    ap.add_argument("--scales", default="1,0.01", help="factors on each method's epsilon, comma-separated")
    ap.add_argument("--tie", type=float, default=TIE, help="relative gap in mean steps that counts as a tie")
    args = ap.parse_args()
    scales = [float(x) for x in args.scales.split(",") if x.strip()]
    if not scales or any(not math.isfinite(s) or s <= 0 for s in scales):
        raise SystemExit(f"--scales must be positive numbers, got {args.scales!r}")
    predictor = Predictor.load(resolve_weights(args.weights), threads=1, backend="torch", symmetries=args.symmetries)
    preset = probe_preset(args)
    cases = cases_of(args.set, args.grid, args.per_family, predictor)
    seeds = list(range(args.seeds))
    means: dict[tuple[str, float], np.ndarray] = {}
    print(f"{args.set}, grid {args.grid}: {len(cases)} maps x {len(seeds)} seeds, weights {args.weights}, preset {args.preset}")
    print("| method | epsilon x | geometric mean of steps | path / A* |")
    print("|---|---:|---:|---:|")
    for method, row in (("IQL", "IQL"), ("NDR-QL", "NDR-QL (model)")):
        for s in scales:
            steps, ratios = [], []
            for _, case, pr in cases:
                q, p = row_configs(preset, grid=case.n)[row]
                st = runs(case, method, replace(q, epsilon=q.epsilon * s), p, pr if method == "NDR-QL" else None, seeds)
                steps.append(st[:, 0].mean())
                ratios.extend(x for x in st[:, 1] if not math.isnan(x))
            means[method, s] = np.array(steps)
            print(f"| {method} | {s:g} | {math.exp(np.mean(np.log(steps))):,.0f} | {np.mean(ratios):.3f} |", flush=True)
    print()
    print(f"| NDR-QL epsilon x | IQL epsilon x | won | tied (within {100 * args.tie:.1f}%) | lost by more |")
    print("|---:|---:|---:|---:|---:|")
    for s in scales:
        for t in scales:
            won, tied, lost = against_iql(means["NDR-QL", s], means["IQL", t], args.tie)
            print(f"| {s:g} | {t:g} | {won} | {tied} | {lost} |")


if __name__ == "__main__":
    main()
