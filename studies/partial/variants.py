#!/usr/bin/env python3
"""How a belief model's outputs become priors on a belief map (issue 54, development set only).

``model_eval.py`` feeds the model's region, guideline and distance to NDR-QL as on a known map (Eq. 6's mask,
Eqs. 3-4's guideline rewards). On a belief map that commits the agent to a route a hidden wall may cut. The
rows here keep the model and change only how its outputs enter Q-learning, each a ratio to IQL-BFS (belief):

- ``NDR-QL``: as ``model_eval.py``;
- ``IQL (model distance)``: IQL-BFS's rewards and Eq. 5 with ``dist`` the model's predicted goal distance;
- ``IQL (lower bound)``: Eq. 5 with ``max(model distance, belief BFS distance)``: with unknown cells counted
  free the belief's BFS distance can only be shorter than the truth's, so the maximum keeps what the model adds
  (detours) and never promises less than the belief allows;
- ``NDR-QL (lower bound)``: NDR-QL with that distance and its region;
- ``NDR-QL (no mask)``: that, with Eq. 6's mask term off (no threshold); ``NDR-QL (no mask, model distance)``: the
  model's own distance there (what ``plan`` builds from the model source); ``NDR-QL (no guideline)``: with a zero
  guideline (Eq. 4's guideline reward and the tie-break off); ``NDR-QL (IQL constants)``: NDR-QL's priors built
  and learned with IQL-BFS's constants of the preset; ``exact (no mask)``: no model, the belief's exact priors
  (its shortest path drawn as the labels are, its BFS distance), Eq. 6's mask off: what the model must beat.

    PYTHONPATH=src python studies/partial/variants.py --weights W.pt --grids 50 --out /tmp/variants50.jsonl
    PYTHONPATH=src python studies/partial/variants.py --report /tmp/variants50.jsonl
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ndrql.experiments.partial import steps_of  # noqa: E402
import model_eval  # noqa: E402

from ndrql.experiments.stats import geomean_ratio, outcomes  # noqa: E402
from ndrql.model.predict import Predictor  # noqa: E402
from ndrql.pipeline.sources import belief_floor, drawn_priors  # noqa: E402
from ndrql.planning import priors as P  # noqa: E402
from ndrql.planning.methods import Priors, build_priors  # noqa: E402
from ndrql.planning.preset import load_preset  # noqa: E402
from ndrql.planning.priors import ThresholdWarning  # noqa: E402
from ndrql.planning.runner import astar_length, run_plan  # noqa: E402

REF = "IQL-BFS (belief)"


def iql_with(blocked, goal, cfg, dist) -> Priors:
    return Priors(r_c=np.ascontiguousarray(P.d_crf(blocked.shape, goal, cfg)),
                  q0=np.ascontiguousarray(P.d_qi(blocked, goal, dist)), threshold=None)


def rows_for(case, bcase, unknown, model: Predictor, preset, seeds) -> dict:
    n = max(case.blocked.shape)
    s, g = case.start_cell, case.goal_cell
    opt = astar_length(case.blocked, s, g)
    out = model.predict_view(bcase.blocked, s, g, unknown=unknown if model.sees_unknown else None)
    ql_i, cfg_i = preset.configs("IQL-BFS", grid=n)
    ql_n, cfg_n = preset.configs("NDR-QL", grid=n)
    ex = drawn_priors("exact", bcase.blocked, s, g, None)
    lower = belief_floor(out.distance, bcase.blocked, g)  # what plan builds on a belief map
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ThresholdWarning)
        jobs = {REF: ("IQL-BFS", ql_i, build_priors("IQL-BFS", bcase.blocked, s, g, cfg=cfg_i)),
                "NDR-QL": ("NDR-QL", ql_n, build_priors("NDR-QL", bcase.blocked, s, g, out.region, out.guideline,
                                                        cfg_n, out.distance)),
                "IQL (model distance)": ("IQL-BFS", ql_i, iql_with(bcase.blocked, g, cfg_i, np.asarray(out.distance, float))),
                "IQL (lower bound)": ("IQL-BFS", ql_i, iql_with(bcase.blocked, g, cfg_i, lower)),
                "NDR-QL (lower bound)": ("NDR-QL", ql_n, build_priors("NDR-QL", bcase.blocked, s, g, out.region,
                                                                      out.guideline, cfg_n, lower)),
                "NDR-QL (no mask)": ("NDR-QL", ql_n, build_priors("NDR-QL", bcase.blocked, s, g, out.region,
                                                                  out.guideline, cfg_n, lower, threshold=None)),
                "NDR-QL (no mask, model distance)": ("NDR-QL", ql_n, build_priors(
                    "NDR-QL", bcase.blocked, s, g, out.region, out.guideline, cfg_n, out.distance, threshold=None)),
                "NDR-QL (no mask, no guideline)": ("NDR-QL", ql_n, build_priors(
                    "NDR-QL", bcase.blocked, s, g, out.region, np.zeros_like(out.guideline), cfg_n, lower, threshold=None)),
                "NDR-QL (no guideline)": ("NDR-QL", ql_n, build_priors("NDR-QL", bcase.blocked, s, g, out.region,
                                                                       np.zeros_like(out.guideline), cfg_n, lower)),
                "NDR-QL (IQL constants)": ("IQL-BFS", ql_i, build_priors("NDR-QL", bcase.blocked, s, g, out.region,
                                                                         out.guideline, cfg_i, lower)),
                "exact (no mask)": ("NDR-QL", ql_n, build_priors("NDR-QL", bcase.blocked, s, g, ex.region, ex.guideline,
                                                                 cfg_n, ex.distance, threshold=None))}
    rows = {}
    for name, (method, ql, pri) in jobs.items():
        runs = [run_plan(case.blocked, s, g, method, k, ql, priors=pri, astar=opt) for k in seeds]
        rows[name] = {"steps": [steps_of(r) for r in runs], "ratio": [r.length_ratio for r in runs]}
    return rows


def measure(args) -> int:
    model = Predictor.load(args.weights, threads=1)
    preset, seeds = load_preset("general"), list(range(args.seeds))
    with Path(args.out).open("a") as f:
        for grid in [int(x) for x in args.grids.split(",")]:
            for pc in model_eval.cases(args, grid):
                if pc.case is None:
                    continue
                rec = {"index": pc.index, "family": pc.family, "grid": grid,
                       "rows": rows_for(pc.case, pc.bcase, pc.unknown, model, preset, seeds)}
                f.write(json.dumps(rec) + "\n")
                f.flush()
    return 0


def report(files) -> int:
    recs = [json.loads(x) for f in files for x in Path(f).read_text().splitlines() if x.strip()]
    mean = lambda r, m: float(np.mean(r["rows"][m]["steps"]))  # noqa: E731
    for grid in sorted({r["grid"] for r in recs}) + [0]:
        group = [r for r in recs if grid in (0, r["grid"])]
        print(f"\n### grid {grid or 'all'}: {len(group)} maps")
        for m in group[0]["rows"]:
            if m == REF:
                continue
            gm = geomean_ratio([mean(r, m) for r in group], [mean(r, REF) for r in group])
            o = outcomes([r["rows"][m]["steps"] for r in group], [r["rows"][REF]["steps"] for r in group])
            fams = sorted({r["family"] for r in group})
            worst = max((geomean_ratio([mean(r, m) for r in group if r["family"] == fa],
                                       [mean(r, REF) for r in group if r["family"] == fa])["ratio"], fa) for fa in fams)
            print(f"- {m}: {gm['ratio']:.3f} ({gm['low']:.3f} .. {gm['high']:.3f}) W/T/L {o['wins']}/{o['ties']}/"
                  f"{o['losses']}; worst family {worst[1]} {worst[0]:.3f}")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--weights", default="")
    ap.add_argument("--set", default="partial-dev")
    ap.add_argument("--grids", default="50,100")
    ap.add_argument("--kind", default="blobs")
    ap.add_argument("--fraction", type=float, default=0.3)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--limit", type=int, default=None)
    ap.add_argument("--out", default="results/partial/variants.jsonl")
    ap.add_argument("--report", nargs="+")
    args = ap.parse_args(argv)
    return report(args.report) if args.report else measure(args)


if __name__ == "__main__":
    sys.exit(main())
