"""The probe of the rule "the propagating head on merged cells above 256 cells" (large_view/history.md): on every map of
the development sets planned on more than 256 cells, the shipped head's region at full resolution and on the grid
with 2 x 2 cells merged (``merge_walls``), each judged by ``plan``'s own test on the planning grid.

    PYTHONPATH=src python studies/propagate/coarse_probe.py [--sets large-dev2-256,large-dev-256,large-tune-256]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from ndrql.dataset.render import merge_walls
from ndrql.experiments.ceiling import grid_case, larger_sizes
from ndrql.experiments.eval_sets import eval_set, eval_spec
from ndrql.model import propagation
from ndrql.pipeline.fallback import region_verdict
from ndrql.planning.preset import load_preset


def merged_head(blocked: np.ndarray, s, g, f: int) -> np.ndarray:
    """The head on the grid with ``f`` x ``f`` cells merged as the ``walls`` view merges them, each merged cell's
    probability given back to its cells, 0 on blocked ones (the change the rule judged; not adopted)."""
    small = propagation.propagate(merge_walls(blocked, f, s, g), (s[0] // f, s[1] // f), (g[0] // f, g[1] // f),
                                  threads=1)
    return np.where(blocked, 0.0, np.kron(small, np.ones((f, f)))[: blocked.shape[0], : blocked.shape[1]])


def judge(blocked, s, g, f: int) -> dict:
    t = time.perf_counter()
    prob = propagation.propagate(blocked, s, g, threads=1) if f == 1 else merged_head(blocked, s, g, f)
    sec = time.perf_counter() - t
    cfg = load_preset("general").configs("NDR-QL", grid=int(max(blocked.shape)))[1]  # what plan judges with
    thd, cover, why = region_verdict(prob, blocked, s, g, cfg)
    return {"ok": why is None, "thd": thd, "cover": cover, "why": why, "seconds": sec}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sets", default="large-dev2-256,large-dev-256,large-tune-256")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    rows = []
    for name in a.sets.split(","):
        gs = eval_set(eval_spec(name), progress=False)
        for i in range(len(gs)):
            fam = str(gs.families[i])
            key = f"{fam}-{i}-g256"
            raw = gs.raw(i)
            case = grid_case(key, fam, raw.obstacles, raw.start, raw.goal, 256, larger_sizes(256))
            if case is None or max(case.blocked.shape) <= 256:
                continue
            full = judge(case.blocked, case.start_cell, case.goal_cell, 1)
            merged = judge(case.blocked, case.start_cell, case.goal_cell, 2)
            rows.append({"set": name, "key": key, "n": int(max(case.blocked.shape)), "full": full, "merged": merged})
            print(f"{name} {key} n={rows[-1]['n']} full ok={full['ok']} ({full['seconds']:.1f}s, {full['why']}) "
                  f"merged ok={merged['ok']} ({merged['seconds']:.1f}s, {merged['why']})", flush=True)
    f_ok = [r["full"]["ok"] for r in rows]
    m_ok = [r["merged"]["ok"] for r in rows]
    both = sum(a and b for a, b in zip(f_ok, m_ok))
    print(f"maps {len(rows)}: full passes {sum(f_ok)}, merged {sum(m_ok)}, both {both}; merged keeps "
          f"{both / max(1, sum(f_ok)):.0%} of full's passes; seconds median full "
          f"{np.median([r['full']['seconds'] for r in rows]):.2f}, merged {np.median([r['merged']['seconds'] for r in rows]):.2f}")
    if a.out:
        json.dump(rows, open(a.out, "w"), indent=1, default=float)


if __name__ == "__main__":
    main()
