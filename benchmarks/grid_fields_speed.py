"""The grid fields of the priors stage on large grids, each against a reference measured in the same run.

    .venv/bin/python benchmarks/grid_fields_speed.py [--sizes 50,128,256,600] [--repeat 3] [--family rooms]

On a generated map (``ndrql.synth.families``, ``--family``, the map itself is the planning grid; the start is a
random free cell and the goal the free cell farthest from it by moves), per grid size:

1. the move counts to the goal: the pure-Python deque BFS that ``bfs_distances`` ran before (kept below) against
   the compiled :func:`ndrql.maps.fields.bfs4` that it runs now; both fields are checked equal;
2. Eq. 7's threshold: the galloping search over ``region_connects`` that ``adaptive_threshold`` ran before (kept
   below) against the one pass over the widest path that it runs now, on the paper's schedule and on the
   ``general`` preset's NDR-QL schedule for the grid; both answers are checked equal. The region is the oracle's
   (``ndrql.synth.oracle.oracle_prediction``) blurred and mixed with noise, so the threshold falls mid-schedule
   and the galloping search asks several times;
3. the whole priors stage, :func:`ndrql.planning.methods.build_priors`, for IQL-BFS (IQL with the exact BFS
   distance) and NDR-QL (the ``general`` preset's constants for the grid, with the oracle's guideline and a
   noisy exact distance as the predicted one; once more with ``region_dilation`` 1), as a multiple of the
   compiled BFS field of item 1.

Each figure is the least CPU time of ``--repeat`` calls after one warm-up call (compiled kernels loaded, scipy
not imported), in ms. One process, one thread: CPU time is the call's wall time on an idle machine, and on a
shared one it leaves out the waits for a core (caches shared with other jobs still slow it).
"""

from __future__ import annotations

import argparse
import dataclasses
import time
import warnings
from collections import deque

import numpy as np

from ndrql.maps import native
from ndrql.maps.fields import bfs4
from ndrql.maps.grid import MOVES4
from ndrql.planning.config import PriorConfig
from ndrql.planning.methods import build_priors
from ndrql.planning.preset import load_preset
from ndrql.planning.priors import (ThresholdWarning, adaptive_threshold, exact_distance, gaussian_blur,
                                   region_connects, threshold_schedule)
from ndrql.synth.families import generate_map
from ndrql.synth.oracle import oracle_prediction


def python_bfs(blocked: np.ndarray, source: tuple[int, int]) -> np.ndarray:
    """``bfs_distances`` before it was compiled: a deque BFS in Python."""
    h, w = blocked.shape
    dist = np.full((h, w), -1, dtype=np.int64)
    if blocked[source]:
        return dist
    dist[source] = 0
    queue = deque([source])
    while queue:
        r, c = queue.popleft()
        d = dist[r, c] + 1
        for dr, dc in MOVES4:
            nr, nc = r + dr, c + dc
            if 0 <= nr < h and 0 <= nc < w and dist[nr, nc] < 0 and not blocked[nr, nc]:
                dist[nr, nc] = d
                queue.append((nr, nc))
    return dist


def galloping_threshold(region, blocked, start, goal, cfg: PriorConfig) -> float | None:
    """``adaptive_threshold`` before the one pass: a galloping search down the schedule over region_connects."""
    schedule = threshold_schedule(cfg)
    connects = lambda i: region_connects(region, blocked, start, goal, schedule[i])  # noqa: E731
    lo, probe, step = 0, 0, 1
    while probe < len(schedule) and not connects(probe):
        lo, probe, step = probe + 1, probe + step, 2 * step
    hi = min(probe, len(schedule))
    while lo < hi:
        mid = (lo + hi) // 2
        if connects(mid):
            hi = mid
        else:
            lo = mid + 1
    return schedule[lo] if lo < len(schedule) else None


def best_of(fn, repeat: int) -> tuple[float, object]:
    """The least CPU time of ``repeat`` calls after one warm-up call, and the answer (CPU time: on a machine shared
    with other jobs a call's wall time also counts the time it waited for a core)."""
    out = fn()
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return min(times), out


def problem(family: str, n: int, seed: int):
    """A generated ``n`` x ``n`` grid, a random free start, the farthest free goal, a soft region and the rest."""
    rng = np.random.default_rng([seed, n])
    blocked = generate_map(family, rng, n, n)
    free = np.argwhere(~blocked)
    start = tuple(int(v) for v in free[rng.integers(len(free))])
    moves = bfs4(blocked, start)
    goal = tuple(int(v) for v in np.unravel_index(int(np.argmax(moves)), moves.shape))
    oracle_region, guideline = (a.astype(np.float64) for a in oracle_prediction(blocked, start, goal, px_per_cell=1))
    region = np.clip(0.7 * gaussian_blur(oracle_region, 1.5) + 0.3 * rng.random((n, n)), 0.0, 1.0)
    distance = np.maximum(exact_distance(blocked, goal) + rng.normal(0.0, 2.0, (n, n)), 0.0)
    return blocked, start, goal, region, guideline, distance


def ms(seconds: float) -> str:
    return f"{1e3 * seconds:.2f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="50,128,256,600", help="comma-separated grid sides in cells")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--family", default="rooms")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",") if s]
    preset = load_preset("general")
    print(f"kernels: {native.backend()}; map family {args.family}, seed {args.seed}; "
          f"least CPU time of {args.repeat} calls (ms)\n")
    print("| grid | Python BFS | bfs4 | faster | schedule | thd | galloping | one pass | faster | IQL-BFS | x BFS "
          "| NDR-QL | x BFS | NDR-QL dil. 1 | x BFS |")
    print("|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for n in sizes:
        blocked, start, goal, region, guideline, distance = problem(args.family, n, args.seed)
        t_py, ref = best_of(lambda: python_bfs(blocked, goal), args.repeat)
        t_bfs, got = best_of(lambda: bfs4(blocked, goal), args.repeat)
        if not np.array_equal(ref, got):
            raise SystemExit(f"grid {n}: bfs4 differs from the Python BFS")
        ndr_cfg = preset.configs("NDR-QL", grid=n)[1]
        iql_cfg = preset.configs("IQL-BFS", grid=n)[1]
        t_iql, _ = best_of(lambda: build_priors("IQL-BFS", blocked, start, goal, cfg=iql_cfg), args.repeat)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ThresholdWarning)
            t_ndr, _ = best_of(lambda: build_priors("NDR-QL", blocked, start, goal, region, guideline, ndr_cfg,
                                                    distance=distance), args.repeat)
            wide = dataclasses.replace(ndr_cfg, region_dilation=1)
            t_wide, _ = best_of(lambda: build_priors("NDR-QL", blocked, start, goal, region, guideline, wide,
                                                     distance=distance), args.repeat)
        for name, cfg in (("paper", PriorConfig()), ("preset", ndr_cfg)):
            t_old, thd_old = best_of(lambda: galloping_threshold(region, blocked, start, goal, cfg), args.repeat)
            t_new, thd_new = best_of(lambda: adaptive_threshold(region, blocked, start, goal, cfg), args.repeat)
            if thd_old != thd_new:
                raise SystemExit(f"grid {n}, {name} schedule: one pass gave {thd_new}, the galloping search {thd_old}")
            thd = "none" if thd_new is None else f"{thd_new:.3f}"
            if name == "paper":
                print(f"| {n} | {ms(t_py)} | {ms(t_bfs)} | {t_py / t_bfs:.0f}x | {name} | {thd} | {ms(t_old)} | "
                      f"{ms(t_new)} | {t_old / t_new:.0f}x | {ms(t_iql)} | {t_iql / t_bfs:.1f} | {ms(t_ndr)} | "
                      f"{t_ndr / t_bfs:.1f} | {ms(t_wide)} | {t_wide / t_bfs:.1f} |", flush=True)
            else:
                print(f"| | | | | {name} | {thd} | {ms(t_old)} | {ms(t_new)} | {t_old / t_new:.0f}x | | | | | | |",
                      flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
