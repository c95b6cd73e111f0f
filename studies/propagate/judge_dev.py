"""The adoption rule's figures for the propagating head (large_view/history.md, "A propagating head where everything
else fails"): a development transfer run with the head, and the same run replayed without it (the maps the head
served counted at IQL's steps, as ``plan`` did before).

    PYTHONPATH=src python studies/propagate/judge_dev.py DIR/summary.json
"""

from __future__ import annotations

import json
import sys

import numpy as np

from ndrql.experiments.transfer_report import plan_steps, uninformative


def _head(r: dict) -> dict:
    return (r.get("second_opinion") or {}).get("propagated") or {}


def _g(x) -> float:
    return float(np.exp(np.mean(np.log(x))))


def main(path: str) -> None:
    recs = [r for r in json.load(open(path))["records"] if not r["skipped"]]
    iql = {r["key"]: np.mean(r["runs"]["IQL"]["steps"]) for r in recs}
    after = {r["key"]: np.mean(plan_steps(r)) for r in recs}
    before = {r["key"]: (iql[r["key"]] if _head(r).get("served") else after[r["key"]]) for r in recs}
    served = [r for r in recs if _head(r).get("served")]
    un_after = sum(uninformative(r) for r in recs)
    print(f"maps {len(recs)}; plan/IQL before {_g([before[k] / iql[k] for k in iql]):.4f} "
          f"after {_g([after[k] / iql[k] for k in iql]):.4f}; uninformative before {un_after + len(served)} after "
          f"{un_after}; head asked {sum(bool(_head(r)) for r in recs)} served {len(served)}")
    for fam in sorted({r["family"] for r in recs}):
        ks = [r["key"] for r in recs if r["family"] == fam]
        b, a = _g([before[k] / iql[k] for k in ks]), _g([after[k] / iql[k] for k in ks])
        print(f"  {fam:15s} {b:.3f} -> {a:.3f}{' SLOWER' if a > 1 else ''}")
    for r in served:
        k = r["key"]
        worst = max(v for v in r["runs"]["NDR-QL (model)"]["ratio"] if v)
        print(f"   served: {k} size {r['size']} plan/IQL {after[k] / iql[k]:.2f} worst path {worst:.2f}")
    pred = [r["seconds"]["prediction"] for r in recs]
    print(f"prediction s: median {np.median(pred):.3f} p95 {np.percentile(pred, 95):.3f} max {max(pred):.2f}")


if __name__ == "__main__":
    main(sys.argv[1])
