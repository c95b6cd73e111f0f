"""Q-learning speed: the compiled kernel against the numpy-in-a-Python-loop reference.

Both implementations make *the same run* (same rules, same random stream, same map, same seed):
the script checks that their Q-tables are bit-identical before it reports anything. Then it
measures the kernel alone on full runs (to convergence) over many seeds, on one core.

    .venv/bin/python benchmarks/qlearning_speed.py            # prints figures
    .venv/bin/python benchmarks/qlearning_speed.py --check    # exit 1 below the floors
    .venv/bin/python benchmarks/qlearning_speed.py --kernels numba   # numba's kernel (default: the one
                                                                     # plan runs, C when built)

Floors (issue 3): kernel >= 40 M steps/s on one core on a 50x50 map, and >= 100x the numpy loop.
Times are the CPU time of this (single) thread (``time.thread_time``), so the figures are per core
and do not count time the scheduler gives to other processes on a busy machine.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from ndrql.planning import rng, rules
from ndrql.planning.config import QLConfig
from ndrql.planning.methods import build_priors
from ndrql.planning import reference
from ndrql.experiments.report import machine, machine_line

FLOOR_KERNEL = 40e6
FLOOR_RATIO = 100.0


def synthetic_map() -> tuple[np.ndarray, tuple[int, int], tuple[int, int], str]:
    """A 50x50 map with two offset walls (a detour both ways)."""
    blocked = np.zeros((50, 50), dtype=bool)
    blocked[16, :38] = True
    blocked[33, 12:] = True
    blocked[4:12, 25] = True
    return blocked, (0, 0), (49, 49), "synthetic 50x50 (two walls)"


def dataset_map(root: Path) -> tuple[np.ndarray, tuple[int, int], tuple[int, int], str] | None:
    """SEEN sample 0 on the 50x50 planning grid, if the dataset is present."""
    if not (root / "TEST" / "SEEN").is_dir():
        return None
    from ndrql.dataset.layout import load_sample
    from ndrql.maps.grid import PlanningGrid

    s = load_sample(root, "seen", 0)
    pg = PlanningGrid.from_map(s.map, s.start, s.goal)
    return pg.blocked, pg.start, pg.goal, "dataset SEEN 0 (50x50 planning grid)"


def kernel_run(blocked, start, goal, r_c, q0, seed, cfg: QLConfig):
    from ndrql.planning import compiled

    h, w = blocked.shape
    q = q0.copy()
    t = time.thread_time()
    out = compiled.train(
        rules.next_table(blocked), rules.cell_index(start, w), rules.cell_index(goal, w), r_c.ravel(), q, seed,
        cfg.alpha, cfg.gamma, rng.eps_threshold(cfg.epsilon), cfg.steps_cap(h * w), cfg.max_episodes, cfg.window,
        cfg.reward_collision, cfg.reward_goal, cfg.reward_revisit,
    )
    dt = time.thread_time() - t
    n = int(out[0])
    return q, int(out[1][:n].sum()), dt, out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--episodes", type=int, default=30, help="episodes of the same-run comparison (default 30)")
    ap.add_argument("--seeds", type=int, default=20, help="seeds of the kernel-only full runs (default 20)")
    ap.add_argument("--method", default="QL", help="method whose priors are used (default QL)")
    ap.add_argument("--dataset", type=Path, default=Path(__file__).resolve().parents[2] / "shared/data/path-planning-dataset")
    ap.add_argument("--check", action="store_true", help="exit 1 when a floor is not met")
    ap.add_argument("--kernels", choices=("auto", "c", "numba"), default=None,
                    help="which compiled kernel (sets NDRQL_KERNELS; default: as the environment says, else auto)")
    args = ap.parse_args(argv)
    if args.kernels:
        os.environ["NDRQL_KERNELS"] = args.kernels

    from ndrql.planning import compiled

    compiled.warm_up()
    print(f"machine: {machine_line(machine())}")
    print(f"kernel: {compiled.backend()} (NDRQL_KERNELS={os.environ.get('NDRQL_KERNELS', 'auto')})")
    print(f"method {args.method}, alpha 0.1, epsilon 0.2, gamma 0.95, max_steps 4 x cells, W 20; one core\n")
    maps = [synthetic_map()]
    real = dataset_map(args.dataset)
    if real is not None:
        maps.append(real)
    ok = True
    for blocked, start, goal, name in maps:
        pr = build_priors(args.method, blocked, start, goal)
        cfg = QLConfig(max_episodes=args.episodes)
        t = time.thread_time()
        ref = reference.train(blocked, start, goal, pr.r_c, pr.q0, 0, cfg)
        ref_dt = time.thread_time() - t
        ref_steps = sum(ref.steps)
        times = []
        for _ in range(7):
            q, k_steps, k_dt, _ = kernel_run(blocked, start, goal, pr.r_c, pr.q0, 0, cfg)
            times.append(k_dt)
        if not (np.array_equal(q, ref.q) and k_steps == ref_steps):
            print(f"{name}: kernel and numpy loop DISAGREE; not a same-run comparison", file=sys.stderr)
            return 1
        k_dt = statistics.median(times)
        ref_rate, k_rate = ref_steps / ref_dt, k_steps / k_dt
        print(f"{name}: same run, seed 0, first {len(ref.steps)} episodes, {ref_steps:,} steps, Q-tables identical")
        print(f"  numpy loop : {ref_rate / 1e6:8.3f} M steps/s  ({ref_dt:.2f} s CPU)")
        print(f"  kernel     : {k_rate / 1e6:8.3f} M steps/s  ({k_dt * 1e3:.2f} ms, CPU, median of 7)")
        print(f"  ratio      : {k_rate / ref_rate:8.0f} x")
        # kernel only: full runs to convergence, many seeds
        full = QLConfig()
        total_steps = 0
        total_time = 0.0
        conv = 0
        for seed in range(args.seeds):
            _, n_steps, dt, out = kernel_run(blocked, start, goal, pr.r_c, pr.q0, seed, full)
            total_steps += n_steps
            total_time += dt
            conv += int(out[5]) >= 0
        full_rate = total_steps / total_time
        print(f"  kernel, full runs: {args.seeds} seeds, {conv} converged, {total_steps:,} steps in {total_time:.3f} s CPU"
              f" -> {full_rate / 1e6:.2f} M steps/s\n")
        ok &= full_rate >= FLOOR_KERNEL and k_rate / ref_rate >= FLOOR_RATIO
    verdict = "met" if ok else "NOT met"
    print(f"floors (>= {FLOOR_KERNEL / 1e6:.0f} M steps/s full runs, >= {FLOOR_RATIO:.0f}x the numpy loop): {verdict}")
    return 0 if ok or not args.check else 1


if __name__ == "__main__":
    sys.exit(main())
