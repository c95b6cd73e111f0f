#!/usr/bin/env python3
"""Where the oracle's gain over the model comes from on belief maps (issue 54; analysis, no choice).

On the cached cases of :mod:`tune_belief` (a development set, its belief and true grids, the shipped weights'
prediction, IQL-BFS (belief)'s steps), NDR-QL with the shipped ``belief`` preset's constants runs with its priors
taken part from the oracle (the true grid's exact region, guideline and distance), part from the prediction:

- ``model``: everything predicted, built on the belief, Eq. 6's mask off (what ``plan --hide`` runs);
- ``oracle distance``: the predicted region and guideline, the true goal distance;
- ``oracle region``: the oracle's region and guideline, the predicted (floored) distance;
- ``oracle on belief``: all three from the oracle, built on the belief, mask off;
- ``oracle``: the ceiling of ``ndrql reproduce partial`` (the oracle's priors built on the true grid, mask on).

    PYTHONPATH=src python studies/partial/decompose.py --set partial-dev-b --grid 50
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from sym_check import case_parser  # noqa: E402
from tune_belief import SEEDS, build_cache  # noqa: E402

from ndrql.experiments.ceiling import GridCase  # noqa: E402
from ndrql.experiments.partial import ndr_priors, steps_of  # noqa: E402
from ndrql.experiments.stats import geomean_ratio  # noqa: E402
from ndrql.pipeline.sources import drawn_priors  # noqa: E402
from ndrql.planning.preset import load_preset  # noqa: E402
from ndrql.planning.runner import run_plan  # noqa: E402

VARIANTS = ("model", "oracle distance", "oracle region", "oracle on belief", "oracle")


def grid_only_case(blocked: np.ndarray, start: tuple, goal: tuple) -> GridCase:
    """A :class:`GridCase` of a planning grid alone (the grid stands for the map: one pixel per cell)."""
    return GridCase(blocked, start, goal, name="cached", group="", n=max(blocked.shape), blocked=blocked,
                    start_cell=start, goal_cell=goal)


def steps(m: dict, variant: str, preset, truth) -> list[int]:
    """NDR-QL's steps per seed on map ``m`` with ``variant``'s priors (``truth``: the oracle's drawn priors)."""
    belief = grid_only_case(m["bblocked"], m["start"], m["goal"])
    if variant == "model":
        pri = ndr_priors(belief, m["region"], m["guideline"], m["distance"], preset, mask=False)
    elif variant == "oracle distance":
        pri = ndr_priors(belief, m["region"], m["guideline"], truth.distance, preset, mask=False)
    elif variant == "oracle region":
        pri = ndr_priors(belief, truth.region, truth.guideline, m["distance"], preset, mask=False)
    elif variant == "oracle on belief":
        pri = ndr_priors(belief, truth.region, truth.guideline, truth.distance, preset, mask=False)
    else:
        pri = ndr_priors(grid_only_case(m["blocked"], m["start"], m["goal"]), truth.region, truth.guideline, truth.distance,
                         preset)
    ql = preset.configs("NDR-QL", grid=m["n"])[0]
    return [steps_of(run_plan(m["blocked"], m["start"], m["goal"], "NDR-QL", s, ql, priors=pri)) for s in SEEDS]


def main(argv: list[str] | None = None) -> int:
    args = case_parser(__doc__, "partial-dev-b").parse_args(argv)
    preset = load_preset("belief")
    out = Path(args.out) / f"decompose-{args.set}-g{args.grid}.jsonl"
    recs = []
    with out.open("w") as f:
        for m in build_cache(args, args.grid):
            truth = drawn_priors("oracle", m["blocked"], m["start"], m["goal"], None)  # once per map
            rec = {"index": m["index"], "family": m["family"], "ref": m["ref"],
                   "rows": {v: steps(m, v, preset, truth) for v in VARIANTS}}
            recs.append(rec)
            f.write(json.dumps(rec) + "\n")
    ref = [np.mean(r["ref"]) for r in recs]
    oracle = geomean_ratio([np.mean(r["rows"]["oracle"]) for r in recs], ref)["ratio"]
    for v in VARIANTS:
        g = geomean_ratio([np.mean(r["rows"][v]) for r in recs], ref)["ratio"]
        share = (1 - g) / (1 - oracle) if oracle < 1 else float("nan")  # as the release report
        print(f"{args.set} g{args.grid} {v}: {g:.3f} of IQL-BFS (belief), {share:.0%} of the oracle's gain")
    return 0


if __name__ == "__main__":
    sys.exit(main())
