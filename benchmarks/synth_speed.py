"""Map engine speed: milliseconds per map of every family at a few sizes (median and worst over seeds).

    python benchmarks/synth_speed.py [--sizes 401,2000,4096] [--seeds 10] [--families maze,office]

Single thread, one process; a redraw (a map whose free space was not open) counts in the time.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from ndrql.synth import family_names, generate_map


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="401,2000", help="comma-separated square map sides in px")
    parser.add_argument("--seeds", type=int, default=10, help="maps per family and size (seeds 0..N-1)")
    parser.add_argument("--families", default=",".join(family_names()))
    args = parser.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",") if s]
    print(f"| family | {' | '.join(f'{s} px median / max (ms)' for s in sizes)} |")
    print("|---|" + "---:|" * len(sizes))
    for name in args.families.split(","):
        cells = []
        for size in sizes:
            times = []
            for seed in range(args.seeds):
                t0 = time.perf_counter()
                generate_map(name, np.random.default_rng(seed), size, size)
                times.append(1000 * (time.perf_counter() - t0))
            cells.append(f"{statistics.median(times):.1f} / {max(times):.1f}")
        print(f"| {name} | {' | '.join(cells)} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
