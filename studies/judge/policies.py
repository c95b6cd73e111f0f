"""Rules 2 and 4 of studies/judge/README.md: policy A (the exact prior) against policy B (the model, judged, then the
exact prior) on the records of ``ndrql reproduce transfer`` runs, with the judge's route cut swept.

For each planned case of a run's ``summary.json`` the case is rebuilt from its evaluation set, the model that serves
the grid predicts once (:func:`ndrql.pipeline.predictions.predict_on_grid`) and the judge
(:func:`ndrql.pipeline.judge.judge`, NDR-QL's constants of the preset at the case's grid) gives its verdict with
no route cut; a cut is then applied to the recorded route ratio. Steps: policy A = the ``NDR-QL (oracle)`` row
(on a known map the exact source is the oracle's drawing); policy B = the ``NDR-QL (model)`` row where the judge
accepts and the old chain had not replaced the prediction (``second_opinion`` empty), the oracle row where it
rejects; cases the old chain served and the new judge accepts have no run of the single forward and are counted
apart. Ratios are geometric means over maps of mean steps against ``IQL (BFS distance)``.

    python studies/judge/policies.py SET_NAME RUN_DIR/summary.json [--preset general]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from ndrql.experiments.ceiling import grid_case, larger_sizes
from ndrql.experiments.eval_sets import eval_set, eval_spec
from ndrql.model.predict import load_predictor
from ndrql.pipeline.judge import judge
from ndrql.pipeline.predictions import predict_on_grid
from ndrql.planning.preset import load_preset, method_configs

MODEL, ORACLE, BFS = "NDR-QL (model)", "NDR-QL (oracle)", "IQL (BFS distance)"
CUTS = (None, 1.25, 1.10, 1.05, 1.00)


def verdicts(set_name: str, records: list[dict], preset: str) -> dict[str, dict]:
    """The judge's verdict (no route cut) and the forward's seconds per case key."""
    gs = eval_set(eval_spec(set_name), progress=False)
    pred = load_predictor("general", threads=1)
    pr = load_preset(preset)
    out = {}
    for r in records:
        i = int(r["key"].rsplit("-g", 1)[0].rsplit("-", 1)[1])
        raw = gs.raw(i)
        case = grid_case(r["key"], r["family"], raw.obstacles, raw.start, raw.goal, r["n"], larger_sizes(r["n"]))
        t0 = time.perf_counter()
        region, guide, _, _ = predict_on_grid(pred, case.blocked, case.start_cell, case.goal_cell)
        secs = time.perf_counter() - t0
        cfg = method_configs(pr, "NDR-QL", grid=case.n)[1]
        v = judge(region, guide, case.blocked, case.start_cell, case.goal_cell, cfg, max_route_ratio=float("inf"))
        out[r["key"]] = {"accepted": v.accepted, "route_ratio": v.route_ratio, "reason": v.reason, "seconds": secs}
    return out


def geo(xs: list[float]) -> float:
    return float(np.exp(np.mean(np.log(xs)))) if xs else float("nan")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("set_name")
    ap.add_argument("summary")
    ap.add_argument("--preset", default="general")
    a = ap.parse_args()
    recs = [r for r in json.load(open(a.summary))["records"] if not r["skipped"]]
    cache = Path(a.summary).with_name("verdicts.json")
    v = json.load(open(cache)) if cache.exists() else verdicts(a.set_name, recs, a.preset)
    cache.write_text(json.dumps(v))
    mean = lambda r, row: float(np.mean(r["runs"][row]["steps"]))  # noqa: E731
    fams = sorted({r["family"] for r in recs})
    print(f"{a.summary}: {len(recs)} maps; model forward median {np.median([x['seconds'] for x in v.values()]):.2f} s")
    a_ratio = {f: geo([mean(r, ORACLE) / mean(r, BFS) for r in recs if r["family"] == f]) for f in fams}
    print(f"policy A (exact): all {geo([mean(r, ORACLE) / mean(r, BFS) for r in recs]):.3f}, worst family "
          f"{max(a_ratio.values()):.3f} ({max(a_ratio, key=a_ratio.get)})")
    for cut in CUTS:
        ratios, fam, missing, accepted = [], {}, 0, 0
        for r in recs:
            x = v[r["key"]]
            ok = x["accepted"] and (cut is None or (x["route_ratio"] is not None and x["route_ratio"] <= cut))
            if ok and r.get("second_opinion"):
                missing += 1
                continue
            accepted += ok
            q = mean(r, MODEL if ok else ORACLE) / mean(r, BFS)
            ratios.append(q)
            fam.setdefault(r["family"], []).append(q)
        worst = max(fam, key=lambda f: geo(fam[f]))
        print(f"policy B, cut {cut}: all {geo(ratios):.3f}, worst family {geo(fam[worst]):.3f} ({worst}); model "
              f"accepted on {accepted} of {len(ratios)}; {missing} without a single-forward run")


if __name__ == "__main__":
    main()
