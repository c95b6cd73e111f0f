"""What the propagating head costs (``ndrql.model.propagation.propagate``, ONNX Runtime), against one forward pass
of the model that serves the same grid (the shipped ``general`` model with its companion, ONNX Runtime), in the same
run, at 128-512 cells.

The head is asked only where the companion, the base, the relay and four orientations all failed
(``ndrql.pipeline.propagated``); it runs one iteration per cell of the grid's side, so its cost grows as the
side cubed, the network's as the side squared. The grid: a development-family map (``maze``, seed 0) on its
planning grid, start and goal in opposite corners' free cells.

    PYTHONPATH=src python benchmarks/propagator_speed.py [--sizes 128,256,512] [--repeat 3] [--threads 1]
"""

from __future__ import annotations

import argparse

import numpy as np

from ndrql.dataset.render import connected_grid
from ndrql.model import propagation
from ndrql.model.predict import Predictor
from ndrql.model.weights import resolve_weights
from ndrql.synth.endpoints import sample_endpoints
from ndrql.synth.families import generate_map
from threshold_speed import best_of  # benchmarks run from this folder: the same timer


def grid_of(n: int) -> tuple[np.ndarray, tuple[int, int], tuple[int, int]]:
    rng = np.random.default_rng(0)
    while True:
        occ = generate_map("maze", rng, 2 * n, 2 * n)
        pair = sample_endpoints(rng, occ)
        placed = None if pair is None else connected_grid(occ, tuple(map(int, pair[0])), tuple(map(int, pair[1])), n)
        if placed is not None:
            return placed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="128,256,512")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args()
    if not propagation.available():
        raise SystemExit("no propagating head is shipped (src/ndrql/data/propagator.onnx)")
    model = Predictor.load(resolve_weights(None), threads=args.threads, backend="onnx")
    print(f"threads {args.threads}")
    print(f"{'cells':>5} {'iterations':>10} {'head s':>8} {'one pass s':>10} {'ratio':>6}")
    for n in (int(v) for v in args.sizes.split(",")):
        b, s, g = grid_of(n)
        model.predict_view(b, s, g)  # the companion loaded before timing
        head = best_of(lambda: propagation.propagate(b, s, g, args.threads), args.repeat)[0]
        one = best_of(lambda: model.predict_view(b, s, g), args.repeat)[0]
        iters = propagation.iterations(b.shape, int(propagation.read_record()["chunk"]))
        print(f"{n:>5} {iters:>10} {head:>8.2f} {one:>10.2f} {head / one:>6.1f}")


if __name__ == "__main__":
    main()
