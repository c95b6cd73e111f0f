#!/usr/bin/env python3
"""NDR-QL with the shipped ``belief`` preset on a development set's beliefs, the prediction averaged over N
orientations (``--symmetries``) or its inferred detour scaled (``--detour-scale L``: the goal distance
``BFS + L (d - BFS)``, ``d`` the prediction floored at the belief's BFS distance); issue 54,
studies/partial/README.md, "The fifth leg". Development data only.

The cases, IQL-BFS (belief)'s steps and the constants are :mod:`tune_belief`'s (its cache of the same weights and
set is read, or built, for the reference's steps); only the prediction is redone with ``--symmetries`` orientations
(:mod:`ndrql.model.symmetry`). One JSON line per map; ``--report`` prints the geometric mean of NDR-QL / IQL-BFS
(belief) per grid and pooled, wins / ties / losses and the worst family.

    PYTHONPATH=src python studies/partial/sym_check.py --weights src/ndrql/data/ndr_belief.pt --symmetries 4 --grid 50
    PYTHONPATH=src python studies/partial/sym_check.py --report results/partial/tune_belief/sym-*.jsonl
"""

from __future__ import annotations

import argparse
import hashlib
import json
import pickle
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from tune_belief import SEEDS, build_cache, cache_path, map_steps, serves  # noqa: E402

from ndrql.experiments.eval_sets import eval_set, eval_spec  # noqa: E402
from ndrql.experiments.partial import BeliefSetting, model_job, partial_cases  # noqa: E402
from ndrql.experiments.stats import geomean_ratio, outcomes  # noqa: E402
from ndrql.maps.grid import bfs_distances  # noqa: E402
from ndrql.model.predict import load_predictor  # noqa: E402
from ndrql.model.weights import resolve_weights  # noqa: E402
from ndrql.pipeline.sources import belief_floor  # noqa: E402
from ndrql.planning.preset import load_preset  # noqa: E402

REF = "IQL-BFS (belief)"
ROW = "NDR-QL (shipped belief)"


def sym_cache(args, grid: int) -> list[dict]:
    """:func:`tune_belief.build_cache`'s maps with the prediction redone over ``args.symmetries`` orientations."""
    base = build_cache(args, grid)
    if args.symmetries == 1:
        return base
    path = cache_path(args, grid).with_name(cache_path(args, grid).stem + f"-sym{args.symmetries}.pkl")
    if path.exists():
        return pickle.loads(path.read_bytes())
    by_index = {m["index"]: m for m in base}
    predictor = load_predictor(str(resolve_weights(args.weights)), 1, "auto", args.symmetries)
    preset = load_preset(args.preset)
    out = []
    for pc in partial_cases(eval_set(eval_spec(args.set), False), grid, BeliefSetting(args.kind, args.fraction)):
        if pc.case is None or pc.index not in by_index:
            continue
        _, pred = model_job(predictor, pc, preset)
        m = dict(by_index[pc.index])
        m.update(region=np.asarray(pred.region, np.float32), guideline=np.asarray(pred.guideline, np.float32),
                 distance=np.asarray(belief_floor(pred.distance, m["bblocked"], m["goal"]), np.float64))
        out.append(m)
    tmp = path.with_suffix(".tmp")
    tmp.write_bytes(pickle.dumps(out))
    tmp.replace(path)
    return out


def scaled(m: dict, factor: float) -> dict:
    """Map ``m`` with its floored distance's detour over the belief's BFS distance times ``factor`` (free cells)."""
    bfs = bfs_distances(m["bblocked"], m["goal"]).astype(np.float64)
    d = np.asarray(m["distance"], np.float64)
    ok = bfs >= 0
    out = d.copy()
    out[ok] = bfs[ok] + factor * np.maximum(d[ok] - bfs[ok], 0.0)
    return {**m, "distance": out}


def run(args) -> int:
    shipped = load_preset("belief")
    w = Path(str(resolve_weights(args.weights)))
    tag = hashlib.sha256(w.read_bytes()).hexdigest()[:12]
    scale = "" if args.detour_scale == 1.0 else f"-x{args.detour_scale:g}"
    out = Path(args.out) / f"sym-{args.set}-g{args.grid}-{tag}-sym{args.symmetries}{scale}.jsonl"
    done = {json.loads(x)["index"] for x in out.read_text().splitlines()} if out.exists() else set()
    with out.open("a") as f:
        for m in sym_cache(args, args.grid):
            if m["index"] in done:
                continue
            ql, pri = shipped.configs("NDR-QL", grid=m["n"])
            if args.detour_scale != 1.0:
                m = scaled(m, args.detour_scale)
            rec = {"index": m["index"], "family": m["family"], "grid": args.grid, "n": m["n"],
                   "entry": serves(shipped, m["n"]), "weights": tag + scale, "symmetries": args.symmetries,
                   "rows": {REF: m["ref"], ROW: map_steps("NDR-QL", m, ql, pri, SEEDS)}}
            f.write(json.dumps(rec) + "\n")
            f.flush()
    print(f"wrote {out}")
    return 0


def summary(recs: list[dict]) -> str:
    if not recs:
        return "0 maps"
    a = [np.mean(r["rows"][ROW]) for r in recs]
    b = [np.mean(r["rows"][REF]) for r in recs]
    g = geomean_ratio(a, b)
    o = outcomes([r["rows"][ROW] for r in recs], [r["rows"][REF] for r in recs])
    fams = sorted({r["family"] for r in recs})
    worst = max((geomean_ratio([np.mean(r["rows"][ROW]) for r in recs if r["family"] == fa],
                               [np.mean(r["rows"][REF]) for r in recs if r["family"] == fa])["ratio"], fa) for fa in fams)
    return (f"{len(recs)} maps {g['ratio']:.3f} ({g['low']:.2f} .. {g['high']:.2f}) W/T/L {o['wins']}/{o['ties']}/"
            f"{o['losses']} worst {worst[1]} {worst[0]:.2f}")


def report(paths: list[str]) -> int:
    for p in paths:
        recs = [json.loads(x) for x in Path(p).read_text().splitlines() if x.strip()]
        print(f"{Path(p).name}: {summary(recs)}")
    groups: dict[tuple, list[dict]] = {}
    for p in paths:
        for x in Path(p).read_text().splitlines():
            if x.strip():
                r = json.loads(x)
                groups.setdefault((r["weights"], r["symmetries"]), []).append(r)
    for (tag, sym), recs in sorted(groups.items()):
        print(f"pooled {tag} sym{sym}: {summary(recs)}")
    return 0


def case_parser(doc: str, set_name: str) -> argparse.ArgumentParser:
    """The options that name :func:`tune_belief.build_cache`'s cases (weights, set, belief, grid, preset, out)."""
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--weights", default="src/ndrql/data/ndr_belief.pt")
    ap.add_argument("--set", default=set_name)
    ap.add_argument("--kind", default="blobs")
    ap.add_argument("--fraction", type=float, default=0.3)
    ap.add_argument("--grid", type=int, default=50)
    ap.add_argument("--preset", default="general", help="the cache's preset (IQL-BFS (belief)'s constants)")
    ap.add_argument("--out", default="results/partial/tune_belief")
    return ap


def main(argv: list[str] | None = None) -> int:
    ap = case_parser(__doc__, "partial-dev-c")
    ap.add_argument("--symmetries", type=int, default=1, choices=(1, 2, 4, 8))
    ap.add_argument("--detour-scale", type=float, default=1.0, help="the inferred detour times this (1: as predicted)")
    ap.add_argument("--report", nargs="*", default=None, metavar="JSONL")
    args = ap.parse_args(argv)
    return report(args.report) if args.report is not None else run(args)


if __name__ == "__main__":
    sys.exit(main())
