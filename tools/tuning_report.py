"""Tables and figures of studies/history.md#tuning from the stored searches and the scale runs.

    .venv/bin/python tools/tuning_report.py      # prints markdown; copies Optuna's plots to docs/tuning/

Reads src/ndrql/planning/presets/tuned.json (search budget, best constants, check on fresh seeds),
results/tune/<method>/best.json and history/importance plots, results/scale/summary.json (spec)
and results/scale-tuned/summary.json (tuned), and prints the budget, the best constants per
method and the improvement of the tuned over the spec constants on the validation maps (TRAIN)
next to the same on the scale study's test maps (TEST/SEEN and TEST/UNSEEN).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from ndrql.experiments.report import md_table  # noqa: E402
from ndrql.io import write_bytes  # noqa: E402
from ndrql.planning.preset import configs_dict, load_preset  # noqa: E402
from ndrql.tuning import space as S  # noqa: E402


def pct(x):
    return "-" if x is None else f"{100 * x:.0f}%"


def main() -> int:
    tuned = load_preset("tuned")
    meta = tuned.meta
    methods = list(tuned.methods)
    out = ["### Search spaces", "", md_table(["constant", "range", "scale", "searched for", "meaning"],
                                              S.space_table(tuple(methods)), ["l", "l", "l", "l", "l"]), ""]
    search = meta["search"]
    out += [f"Budget per method: {search['trials']} trials (the spec point is trial 0), {search['samples']} validation "
            f"maps x seeds {search['seeds']}, episode cap {search['max_episodes']} during the search, TPE seed "
            f"{search['sampler_seed']}.", ""]
    rows = []
    for m in methods:
        best = json.loads((ROOT / "results" / "tune" / m / "best.json").read_text())
        st = meta["studies"][m]
        d = configs_dict(*tuned.configs(m))
        vals = {**d["ql"], **d["priors"]}
        shown = [p.name for p in S.search_space(m)]
        key = {"G": "g_row"}
        consts = ", ".join(f"{n} {vals[key.get(n, n)]:.3g}" for n in shown)
        t = best["trials"]
        rows.append([m, f"{st['best_trial']}", f"{t.get('COMPLETE', 0)} / {t.get('PRUNED', 0)} / {t.get('FAIL', 0)}",
                     f"{best['baseline_spec']['steps']:,.0f}", f"{st['best_steps']:,.0f}" if st["best_steps"] else "-",
                     pct(best["improvement_over_spec"]), consts])
        for kind in ("history", "importance"):
            src = ROOT / "results" / "tune" / m / f"{kind}.png"
            if src.is_file():
                write_bytes(ROOT / "docs" / "tuning" / f"{m}-{kind}.png", src.read_bytes())
    out += ["### Best constants", "", md_table(["method", "best trial", "complete / pruned / failed", "spec steps",
                                                "best steps", "fewer steps than spec", "constants"], rows,
                                               ["l", "r", "r", "r", "r", "r", "l"]), ""]
    check = meta["validation_check"]
    scale = {}
    for name, d in (("spec", "scale"), ("tuned", "scale-tuned")):
        f = ROOT / "results" / d / "summary.json"
        if f.is_file():
            scale[name] = json.loads(f.read_text())["groups"]
    rows = []
    for m in methods:
        c = check[m]
        row = [m, f"{c['spec']['steps']:,.0f}", f"{c['tuned']['steps']:,.0f}", pct(c["improvement"]),
               f"{c['spec']['ratio']:.3f} / {c['tuned']['ratio']:.3f}"]
        if len(scale) == 2 and m in scale["spec"]["all"]:
            a, b = scale["spec"]["all"][m], scale["tuned"]["all"][m]
            imp = 1 - b["steps"]["mean"] / a["steps"]["mean"]
            row += [f"{a['steps']['mean']:,.0f}", f"{b['steps']['mean']:,.0f}", pct(imp),
                    f"{1 + a['gap']['mean']:.3f} / {1 + b['gap']['mean']:.3f}", f"{100 * (c['improvement'] - imp):+.0f} pt"]
        else:
            row += ["-"] * 5
        rows.append(row)
    out += ["### TRAIN vs TEST", "", md_table(
        ["method", "validation spec", "validation tuned", "fewer steps", "greedy/A* spec / tuned",
         "TEST spec", "TEST tuned", "fewer steps", "greedy/A* spec / tuned", "gap (validation - TEST)"], rows), ""]
    print("\n".join(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
