"""Judge the propagation probe: its region on small held-out grids and on the development maps at 256 cells.

    PYTHONPATH=src python studies/propagate/evaluate.py NET.pt --small FILE.npz [--dev large-dev2-256 --keys a,b]

Per grid: the region of "on a shortest route" probabilities judged by ``plan``'s own test
(``ndrql.pipeline.fallback.region_verdict``: Eq. 7's threshold, the region's cover, and why it cannot guide),
recall of the true route at 0.5, and the seconds of the iterations (one thread).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
import torch

from data import on_route
from net import Propagator, inputs
from ndrql.pipeline.fallback import region_verdict
from ndrql.planning.config import PriorConfig


def run(net, blocked, s, g, iters: int) -> tuple[np.ndarray, float]:
    x = inputs(blocked, s, g)[None]
    t = time.perf_counter()
    with torch.inference_mode():
        logit, _ = net(x, iters)
    return torch.sigmoid(logit)[0, 0].numpy(), time.perf_counter() - t


def judge(net, blocked, s, g, per_side: float) -> dict:
    n = max(blocked.shape)
    prob, sec = run(net, blocked, s, g, max(8, int(per_side * n)))
    route = on_route(blocked, s, g)
    thd, cover, why = region_verdict(prob, blocked, s, g, PriorConfig())
    hit = prob > 0.5
    strict = thd is not None and thd >= 0.1 and cover is not None and cover <= 0.5  # the large-grid test at any size
    return {"n": n, "thd": thd, "cover": cover, "why": why, "ok": strict,
            "recall": float((hit & route).sum() / max(1, route.sum())),
            "precision": float((hit & route).sum() / max(1, hit.sum())), "seconds": sec}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("net")
    ap.add_argument("--small", nargs="*", default=[])
    ap.add_argument("--per-side", type=float, nargs="*", default=[1.0, 2.0])
    ap.add_argument("--dev", default=None)
    ap.add_argument("--keys", default=None, help="comma-separated record keys, or @summary.json for its uninformative maps")
    ap.add_argument("--limit", type=int, default=200)
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    torch.set_num_threads(1)
    ck = torch.load(a.net)
    net = Propagator(ck["width"], ck.get("pool", False))
    net.load_state_dict(ck["state"])
    net.eval()
    results = {}
    for path in a.small:
        d = np.load(path, allow_pickle=True)
        for ps in a.per_side:
            rs = [judge(net, d["blocked"][i], tuple(d["start"][i]), tuple(d["goal"][i]), ps)
                  for i in range(min(a.limit, len(d["blocked"])))]
            ok = np.mean([r["ok"] for r in rs])
            print(f"{path.split('/')[-1]} per-side {ps}: informative {ok:.0%}, recall {np.mean([r['recall'] for r in rs]):.2f}, "
                  f"precision {np.mean([r['precision'] for r in rs]):.2f}, {np.median([r['seconds'] for r in rs])*1e3:.0f} ms", flush=True)
            results[f"{path}:{ps}"] = rs
    if a.dev:
        from ndrql.experiments.ceiling import grid_case, larger_sizes
        from ndrql.experiments.eval_sets import eval_set, eval_spec
        from ndrql.experiments.transfer_report import uninformative
        gs = eval_set(eval_spec(a.dev), progress=False)
        keys = None
        if a.keys and a.keys.startswith("@"):
            recs = json.load(open(a.keys[1:]))["records"]
            keys = {r["key"] for r in recs if not r.get("skipped") and uninformative(r, 0.1)}
        elif a.keys:
            keys = set(a.keys.split(","))
        for ps in a.per_side:
            rs = []
            for i in range(len(gs)):
                fam = str(gs.families[i])
                key = f"{fam}-{i}-g256"
                if keys is not None and key not in keys:
                    continue
                raw = gs.raw(i)
                case = grid_case(key, fam, raw.obstacles, raw.start, raw.goal, 256, larger_sizes(256))
                if case is None:
                    continue
                r = judge(net, case.blocked, case.start_cell, case.goal_cell, ps)
                r["key"] = key
                rs.append(r)
                print(f"  {key} n={r['n']} ok={r['ok']} thd={r['thd']} cover={r['cover'] and round(r['cover'], 2)} "
                      f"recall={r['recall']:.2f} prec={r['precision']:.2f} {r['seconds']:.2f}s", flush=True)
            print(f"{a.dev} per-side {ps}: informative {np.mean([r['ok'] for r in rs]):.0%} of {len(rs)}, "
                  f"median {np.median([r['seconds'] for r in rs]):.2f}s", flush=True)
            results[f"{a.dev}:{ps}"] = rs
    if a.out:
        json.dump(results, open(a.out, "w"), indent=1, default=float)


if __name__ == "__main__":
    main()
