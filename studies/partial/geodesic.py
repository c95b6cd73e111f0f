#!/usr/bin/env python3
"""A goal distance built from the predicted region on a belief map (issue 54; development data only).

On the cached cases of :mod:`tune_belief` (a development set's true and belief grids, the shipped weights'
prediction, IQL-BFS (belief)'s steps), NDR-QL runs with the shipped ``belief`` preset's constants and its goal
distance replaced by a region-weighted shortest-path cost on the belief (:func:`region_distance`):

- ``model``: the shipped distance (the prediction floored at the belief's BFS distance);
- ``geo:k``: each known free cell costs 1 to enter, each unknown one ``1 + k (1 - p)``, ``p`` the predicted region;
- ``maxgeo:k``: the larger of ``geo:k`` and the shipped distance;
- ``above100:k``: ``geo:k`` on the maps whose planning size takes the preset's grid-100 entry or a larger one, the
  shipped distance on the others.

    PYTHONPATH=src python studies/partial/geodesic.py --set partial-dev-b --grid 50 --variants model,geo:1,geo:4
"""

from __future__ import annotations

import json
import pickle
import sys
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

sys.path.insert(0, str(Path(__file__).resolve().parent))
from decompose import grid_only_case  # noqa: E402
from sym_check import case_parser  # noqa: E402
from tune_belief import SEEDS, build_cache, serves  # noqa: E402

from ndrql.experiments.eval_sets import eval_set, eval_spec  # noqa: E402
from ndrql.experiments.partial import BeliefSetting, ndr_priors, partial_cases, steps_of  # noqa: E402
from ndrql.experiments.stats import geomean_ratio  # noqa: E402
from ndrql.planning.preset import load_preset, preset_from_dict  # noqa: E402
from ndrql.planning.runner import run_plan  # noqa: E402


def region_distance(blocked: np.ndarray, unknown: np.ndarray, region: np.ndarray, goal: tuple[int, int],
                    k: float) -> np.ndarray:
    """The cheapest cost from each cell to ``goal`` over 4-neighbour moves through free cells of ``blocked``, entering
    a cell costing 1, or ``1 + k (1 - region)`` where ``unknown``; cells that cannot reach the goal take the largest
    finite cost plus their Manhattan distance (as :func:`ndrql.maps.fields.bfs4_filled`)."""
    h, w = blocked.shape
    free = ~np.asarray(blocked, bool)
    cost = np.where(unknown, 1.0 + k * (1.0 - np.clip(region, 0.0, 1.0)), 1.0).ravel()
    idx = np.arange(h * w).reshape(h, w)
    src, dst = [], []
    for a, b in ((idx[:, :-1], idx[:, 1:]), (idx[:-1, :], idx[1:, :])):
        ok = (free.ravel()[a.ravel()]) & (free.ravel()[b.ravel()])
        src += [a.ravel()[ok], b.ravel()[ok]]
        dst += [b.ravel()[ok], a.ravel()[ok]]
    s, d = np.concatenate(src), np.concatenate(dst)
    graph = coo_matrix((cost[s], (s, d)), shape=(h * w, h * w)).tocsr()  # edge v -> u costs entering v
    dist = dijkstra(graph, directed=True, indices=goal[0] * w + goal[1]).reshape(h, w)
    far = ~np.isfinite(dist)
    if far.any():
        rows = np.abs(np.arange(h) - goal[0])[:, None]
        cols = np.abs(np.arange(w) - goal[1])[None, :]
        top = dist[~far].max() if (~far).any() else 0.0
        dist = np.where(far, top + rows + cols, dist)
    return dist


def unknown_masks(args, grid: int) -> dict[int, np.ndarray]:
    """Each map's belief-grid cells holding an unknown pixel, by index (cached beside the cases)."""
    path = Path(args.out) / f"unknown-{args.set}-{args.kind}{args.fraction:g}-g{grid}.pkl"
    if path.exists():
        return pickle.loads(path.read_bytes())
    gs = eval_set(eval_spec(args.set), False)
    out = {pc.index: np.asarray(pc.unknown, bool) for pc in partial_cases(gs, grid, BeliefSetting(args.kind,
                                                                                                  args.fraction))
           if pc.case is not None}
    path.write_bytes(pickle.dumps(out))
    return out


def distance_of(variant: str, m: dict, unknown: np.ndarray, preset=None) -> np.ndarray:
    """Map ``m``'s goal distance under ``variant`` (``above100:k``: ``geo:k`` where the map's planning size takes
    ``preset``'s grid-100 entry or a larger one, the shipped distance elsewhere)."""
    if variant == "model":
        return m["distance"]
    kind, k = variant.split(":")
    if kind == "above100":
        if serves(preset, m["n"]) < 100:
            return m["distance"]
        kind = "geo"
    geo = region_distance(m["bblocked"], unknown, m["region"], m["goal"], float(k))
    return np.maximum(geo, m["distance"]) if kind == "maxgeo" else geo


def main(argv: list[str] | None = None) -> int:
    ap = case_parser(__doc__, "partial-dev-b")
    ap.add_argument("--variants", default="model,geo:1,geo:4,geo:16")
    ap.add_argument("--preset-file", default=None, help="NDR-QL's constants from this preset file (default: belief)")
    ap.add_argument("--tag", default="", help="suffix of the output file")
    args = ap.parse_args(argv)
    preset = preset_from_dict(json.loads(Path(args.preset_file).read_text()), "candidate") if args.preset_file \
        else load_preset("belief")
    variants = args.variants.split(",")
    masks = unknown_masks(args, args.grid)
    out = Path(args.out) / f"geodesic-{args.set}-g{args.grid}{args.tag}.jsonl"
    recs = []
    with out.open("w") as f:
        for m in build_cache(args, args.grid):
            belief = grid_only_case(m["bblocked"], m["start"], m["goal"])
            ql = preset.configs("NDR-QL", grid=m["n"])[0]
            rows = {}
            for v in variants:
                pri = ndr_priors(belief, m["region"], m["guideline"], distance_of(v, m, masks[m["index"]], preset), preset,
                                 mask=False)
                rows[v] = [steps_of(run_plan(m["blocked"], m["start"], m["goal"], "NDR-QL", s, ql, priors=pri))
                           for s in SEEDS]
            rec = {"index": m["index"], "family": m["family"], "n": m["n"], "ref": m["ref"], "rows": rows}
            recs.append(rec)
            f.write(json.dumps(rec) + "\n")
    ref = [np.mean(r["ref"]) for r in recs]
    for v in variants:
        g = geomean_ratio([np.mean(r["rows"][v]) for r in recs], ref)
        print(f"{args.set} g{args.grid} {v}: {g['ratio']:.3f} of IQL-BFS (belief) over {len(recs)} maps")
    return 0


if __name__ == "__main__":
    sys.exit(main())
