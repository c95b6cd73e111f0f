"""Which input should the model see? The ceiling comparison of models trained on different input modes.

For every map of a held-out generated set and every planning grid size, on the safe (conservative)
grid: QL, IQL, NDR-QL with each model's priors and NDR-QL with the oracle's, same seeds. Prints, per
model and grid, the pooled steps against QL, the model's share of the oracle's reduction (pooled and
per family), path / A* and the share of maps where NDR-QL beats IQL.

    .venv/bin/python studies/input_mode_study.py --set DIR --model map=RUN_A/best.pt --model grid=RUN_B/best.pt \
        --grids 50,100 --seeds 5 --per-family 6 --json out/input_mode_study.json

``--model MODE=FILE`` names the input mode the weights were trained on (``map`` or ``grid``); the same
file may be listed once per mode. Results are deterministic for the same set, weights and seeds.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from ndrql.dataset.generated import GeneratedSet
from ndrql.experiments.ceiling import grid_case, model_priors, oracle_priors, run_case, share, summary_rows
from ndrql.model.predict import Predictor


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--set", type=Path, required=True)
    ap.add_argument("--model", action="append", required=True, help="LABEL:MODE=FILE, e.g. shipped:map=src/ndrql/data/ndr_default.pt")
    ap.add_argument("--grids", default="50,100")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--per-family", type=int, default=6)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    gs = GeneratedSet.load(args.set)
    grids = [int(v) for v in args.grids.split(",")]
    seeds = list(range(args.seeds))
    models = []
    for spec in args.model:
        label_mode, _, path = spec.partition("=")
        label, _, mode = label_mode.rpartition(":")
        models.append((label or mode, mode, Predictor.load(path, threads=1, backend="torch")))
    picked: dict[str, list[int]] = {}
    for i in range(len(gs)):
        fam = str(gs.families[i])
        if len(picked.setdefault(fam, [])) < args.per_family:
            picked[fam].append(i)
    out: dict = {"set": str(args.set), "grids": grids, "seeds": seeds, "models": [m[0] for m in models], "rows": {}}
    t0 = time.perf_counter()
    for n in grids:
        results: dict[str, list] = {label: [] for label, _, _ in models}
        skipped = 0
        for fam, ids in picked.items():
            for i in ids:
                raw = gs.raw(i)
                case = grid_case(f"{fam}-{i}", fam, raw.obstacles, raw.start, raw.goal, n)
                if case is None:
                    skipped += 1
                    continue
                base = run_case(case, {"QL": None, "IQL": None, "NDR-QL (oracle)": oracle_priors(case)}, seeds)
                for label, mode, pred in models:
                    res = run_case(case, {"NDR-QL (model)": model_priors(pred, mode, case)}, seeds)
                    merged = type(base)(base.case, base.group, base.n, {**base.steps, **res.steps}, {**base.ratio, **res.ratio},
                                        {**base.threshold, **res.threshold})
                    results[label].append(merged)
        print(f"\n## grid {n} ({sum(len(v) for v in picked.values()) - skipped} maps, {skipped} disconnected on the safe grid, "
              f"{len(seeds)} seeds; {time.perf_counter() - t0:.0f} s so far)")
        for label, res in results.items():
            fams = sorted({r.group for r in res})
            per_fam = {f: share([r for r in res if r.group == f]) for f in fams}
            rows = summary_rows(res, ("QL", "IQL", "NDR-QL (model)", "NDR-QL (oracle)"))
            print(f"\n### model {label}: share of the oracle's reduction {share(res):.3f} pooled; per family: "
                  + ", ".join(f"{f} {v:.2f}" for f, v in per_fam.items()))
            print("| row | steps vs QL | path / A* | beats IQL |\n|---|---:|---:|---:|")
            for r in rows:
                print(f"| {r['row']} | {100 * r['vs_ql']:+.1f}% | {r['path_ratio']:.3f} | {100 * r['beats_iql']:.0f}% |")
            out["rows"][f"{label}@{n}"] = {"share": share(res), "per_family": per_fam, "rows": rows, "maps": len(res)}
        sys.stdout.flush()
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(out, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
