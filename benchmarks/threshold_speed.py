"""Eq. 7's adaptive threshold on large grids: ``adaptive_threshold`` (one pass over the widest path since issue 53;
a galloping search down the schedule before) against the walk down of Sec. 3.3 (every threshold from 0.99 down
until one connects), in the same run, on the model's own predictions.

``plan`` judges a prediction by this threshold (``prediction_quality``), above 128 cells once more for the
companion's region and once for the base's second opinion, and NDR-QI asks it again with the preset's
schedule, so it runs two to four times per plan. The maps: the first ``--maps`` of the development set
``large-dev-256`` on their planning grids (256 cells, or the larger size a map needs), predicted by the
shipped model with its companion. Both answers are checked equal on every map.

    PYTHONPATH=src python benchmarks/threshold_speed.py [--maps 12] [--repeat 3]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from ndrql.experiments.ceiling import grid_case, larger_sizes
from ndrql.experiments.eval_sets import eval_set, eval_spec
from ndrql.model.predict import Predictor
from ndrql.model.weights import resolve_weights
from ndrql.planning.config import PriorConfig
from ndrql.planning.priors import adaptive_threshold, region_connects


def walk_down(region, blocked, start, goal, cfg: PriorConfig) -> float | None:
    """The reference: Sec. 3.3 as written, every threshold from ``thd_start`` down until one connects."""
    n = int(np.floor(cfg.thd_start / cfg.thd_step + 1e-9))
    for i in range(n + 1):
        thd = round(cfg.thd_start - i * cfg.thd_step, 9)
        if thd < 0:
            break
        if region_connects(region, blocked, start, goal, thd):
            return thd
    return None


def best_of(fn, repeat: int) -> tuple[float, object]:
    """The shortest of ``repeat`` timed calls, and the answer."""
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", type=int, default=12)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    gs = eval_set(eval_spec("large-dev-256"), False)
    model = Predictor.load(resolve_weights(None), threads=1, backend="torch")
    cfg = PriorConfig()
    print(f"{'map':>4} {'grid':>5} {'threshold':>9} {'walk ms':>8} {'search ms':>9} {'ratio':>6}")
    ratios, walks, gallops = [], [], []
    for i in range(min(args.maps, len(gs))):
        raw = gs.raw(i)
        case = grid_case(str(i), str(gs.families[i]), raw.obstacles, raw.start, raw.goal, 256, larger_sizes(256))
        if case is None:
            continue
        b, s, g = case.blocked, case.start_cell, case.goal_cell
        region = model.predict_view(b, s, g).region
        t_walk, ref = best_of(lambda: walk_down(region, b, s, g, cfg), args.repeat)
        t_bin, got = best_of(lambda: adaptive_threshold(region, b, s, g, cfg), args.repeat)
        if got != ref:
            raise SystemExit(f"map {i}: adaptive_threshold gave {got}, the walk down {ref}")
        ratios.append(t_walk / t_bin)
        walks.append(t_walk)
        gallops.append(t_bin)
        shown = "none" if ref is None else f"{ref:.2f}"
        print(f"{i:>4} {case.n:>5} {shown:>9} {1e3 * t_walk:>8.1f} {1e3 * t_bin:>9.1f} {t_walk / t_bin:>5.1f}x")
    print(f"median over {len(ratios)} maps: walk {1e3 * statistics.median(walks):.1f} ms, adaptive_threshold "
          f"{1e3 * statistics.median(gallops):.1f} ms, {statistics.median(ratios):.1f}x faster; same threshold on every map")


if __name__ == "__main__":
    main()
