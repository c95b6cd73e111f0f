"""What Eq. 6's distance through the region costs: NDR-QI's initial Q-table (``ndrql.planning.priors.ndr_qi``)
with ``region_distance`` 1 against 0, in the same run, on the same prediction and constants.

The option adds one breadth-first search over the region's cells (``ndrql.planning.priors.region_distance``)
to the priors stage of ``plan``; everything else is unchanged. The maps: the first ``--maps`` of the
development set ``large-dev-256`` on their planning grids (256 cells, or the larger size a map needs),
predicted by the shipped model with its companion, NDR-QL's constants of the ``general`` preset there.

    PYTHONPATH=src python benchmarks/region_distance_speed.py [--maps 12] [--repeat 3]
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import warnings

import numpy as np

from ndrql.experiments.ceiling import grid_case, larger_sizes
from ndrql.experiments.eval_sets import eval_set, eval_spec
from ndrql.model.predict import Predictor
from ndrql.model.weights import resolve_weights
from ndrql.pipeline.predictions import predict_on_grid
from ndrql.planning.preset import load_preset
from ndrql.planning.priors import ThresholdWarning, ndr_qi
from threshold_speed import best_of  # benchmarks run from this folder: the same timer


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", type=int, default=12)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    gs = eval_set(eval_spec("large-dev-256"), False)
    model = Predictor.load(resolve_weights(None), threads=1, backend="torch")
    preset = load_preset("general")
    print(f"{'map':>4} {'grid':>5} {'threshold':>9} {'plain ms':>9} {'through ms':>10} {'ratio':>6}")
    ratios, plains, throughs = [], [], []
    for i in range(args.maps):
        raw = gs.raw(i)
        case = grid_case(f"m{i}", raw.family, raw.obstacles, raw.start, raw.goal, 256, larger_sizes(256))
        b, s, g = case.blocked, case.start_cell, case.goal_cell
        region, guide, _, dist = predict_on_grid(model, b, s, g)
        shipped = preset.configs("NDR-QL", grid=case.n)[1]  # region_distance 1 above 113 cells since 2026-11-27
        cfg, through = (dataclasses.replace(shipped, region_distance=v) for v in (0, 1))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ThresholdWarning)
            thd = ndr_qi(b, s, g, region, cfg, distance=dist, guideline=guide)[1]
            a = best_of(lambda: ndr_qi(b, s, g, region, cfg, distance=dist, guideline=guide), args.repeat)[0]
            c = best_of(lambda: ndr_qi(b, s, g, region, through, distance=dist, guideline=guide), args.repeat)[0]
        plains.append(a)
        throughs.append(c)
        ratios.append(c / a)
        shown = "none" if thd is None else f"{thd:.3f}"
        print(f"{i:>4} {case.n:>5} {shown:>9} {1e3 * a:>9.1f} {1e3 * c:>10.1f} {c / a:>6.2f}")
    print(f"median: plain {1e3 * statistics.median(plains):.1f} ms, through the region "
          f"{1e3 * statistics.median(throughs):.1f} ms, ratio {statistics.median(ratios):.2f} "
          f"(max {max(ratios):.2f}) over {len(ratios)} maps")
    assert np.isfinite(ratios).all()


if __name__ == "__main__":
    main()
