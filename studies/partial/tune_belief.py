#!/usr/bin/env python3
"""NDR-QL's constants searched on belief maps (issue 54, development data only).

The agent learns on the **true** map; NDR-QL's priors are built from the **belief** as ``plan --hide`` builds them
(the belief model's region and guideline, Eq. 6's mask off, the goal distance floored at the belief's BFS distance:
:func:`ndrql.experiments.partial.model_job`). The objective is the geometric mean over maps of NDR-QL's mean
convergence steps / IQL-BFS (belief)'s, IQL-BFS run once per map and seed with the preset's IQL constants (as
``ndrql reproduce partial``). The prediction does not depend on the constants: it is computed once per case and
cached (``--cache``), with IQL-BFS's steps.

The set's maps are split by index: even = search, odd = check. The search (Optuna TPE, seeded; Optuna's
MedianPruner over chunks of the search maps) sees the search half only; ``--check`` evaluates on the check half
(every seed): general's NDR-QL entry, NDR-QL's priors with IQL's constants, IQL-NDR, and the searched constants.

    PYTHONPATH=src nice -n 10 python studies/partial/tune_belief.py --grid 50 --trials 200
    PYTHONPATH=src nice -n 10 python studies/partial/tune_belief.py --grid 50 --check --both
    PYTHONPATH=src python studies/partial/tune_belief.py --report results/partial/tune_belief

``--weights W.pt`` replaces the shipped belief weights (its own cache; give ``--tag`` to keep its files apart);
``--all`` runs the search at each of ``--grids``, the check and the report in one command; ``--write-preset`` writes
the ``belief`` preset from the searches. ``--method IQL-BFS`` searches IQL-BFS's own constants with the same budget
(the fairness row). Each map takes the preset entry its planning size takes (:func:`serves`, as ``plan``): the
search at grid G sees only the maps that entry serves. Sealed sets are refused (:func:`eval_spec`). ``--half all``
searches every map; ``--check-set partial-dev-c`` checks on every map of another set; ``--above`` gives the top
searched grid's entry to every larger grid; ``--with-reference`` writes IQL-BFS's searched entries into the preset.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import pickle
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from ndrql.experiments.eval_sets import eval_set, eval_spec
from ndrql.experiments.partial import BeliefSetting, model_job, partial_cases, plain_priors, steps_of
from ndrql.experiments.stats import geomean_ratio, outcomes
from ndrql.io import write_json
from ndrql.model.predict import load_predictor
from ndrql.model.weights import BELIEF_WEIGHTS, resolve_weights
from ndrql.pipeline.sources import belief_floor
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import build_priors
from ndrql.planning.preset import load_preset, nearest_grid, preset_from_dict
from ndrql.planning.priors import ThresholdWarning
from ndrql.planning.runner import run_plan
from ndrql.tuning.space import ALPHA, EPSILON, GAMMA, G, OMEGA_CRF, OMEGA_QI, R_MAX, Param

SEEDS = (0, 1, 2)
TIES = Param("guideline_ties", 0.0, 0.95, False, "priors", ("guideline_ties",), "guideline's weight in ties (Eq. 6)")
SPACE = {"NDR-QL": (ALPHA, EPSILON, GAMMA, R_MAX, G, OMEGA_CRF, OMEGA_QI, TIES),
         "IQL-BFS": (ALPHA, EPSILON, GAMMA, R_MAX, G)}


# --- the cached cases ----------------------------------------------------------------------------------------


def cache_path(args, grid: int) -> Path:
    w = Path(str(resolve_weights(args.weights)))
    tag = hashlib.sha256(w.read_bytes()).hexdigest()[:12]
    return Path(args.out) / f"cache-{args.set}-{args.kind}{args.fraction:g}-g{grid}-{tag}.pkl"


def build_cache(args, grid: int) -> list[dict]:
    """Per connected map: true and belief grids, the prediction's region, guideline and floored distance, and
    IQL-BFS (belief)'s steps per seed (the preset's IQL constants)."""
    path = cache_path(args, grid)
    if path.exists():
        return pickle.loads(path.read_bytes())
    preset = load_preset(args.preset)
    predictor = load_predictor(str(resolve_weights(args.weights)), 1, "auto", 1)
    gs = eval_set(eval_spec(args.set), False)
    out = []
    for pc in partial_cases(gs, grid, BeliefSetting(args.kind, args.fraction)):
        if pc.case is None:
            continue
        _, pred = model_job(predictor, pc, preset)
        bb = pc.bcase.blocked
        dist = belief_floor(pred.distance, bb, pc.case.goal_cell)
        c = pc.case
        ref = [steps_of(run_plan(c.blocked, c.start_cell, c.goal_cell, "IQL-BFS", s, preset.configs("IQL-BFS", grid=c.n)[0],
                                 priors=plain_priors("IQL-BFS", pc.bcase, preset))) for s in SEEDS]
        out.append({"index": pc.index, "family": pc.family, "n": c.n, "blocked": c.blocked, "bblocked": bb,
                    "start": c.start_cell, "goal": c.goal_cell, "region": np.asarray(pred.region, np.float32),
                    "guideline": np.asarray(pred.guideline, np.float32), "distance": np.asarray(dist, np.float64),
                    "ref": ref})
        print(f"cache g{grid}: map {pc.index} ({pc.family}) IQL-BFS {np.mean(ref):.0f}", flush=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_bytes(pickle.dumps(out))
    tmp.replace(path)
    return out


def with_distance(args, maps: list[dict], grid: int) -> list[dict]:
    """``--distance model``: the cases as cached; ``geo:k`` / ``maxgeo:k``: their goal distance replaced by the
    region-weighted one of :mod:`geodesic`."""
    if args.distance == "model":
        return maps
    from geodesic import distance_of, unknown_masks

    masks = unknown_masks(args, grid)
    return [{**m, "distance": distance_of(args.distance, m, masks[m["index"]])} for m in maps]


# --- the rows ------------------------------------------------------------------------------------------------


def priors_of(row: str, m: dict, cfg: PriorConfig):
    """A row's priors on map ``m``'s belief: NDR-QL as ``plan`` builds them there (no mask, floored distance),
    IQL-NDR (Eq. 5 with that distance), IQL-BFS (the belief's BFS distance)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ThresholdWarning)
        if row == "IQL-BFS":
            return build_priors("IQL-BFS", m["bblocked"], m["start"], m["goal"], cfg=cfg)
        if row == "IQL-NDR":
            return build_priors("IQL-NDR", m["bblocked"], m["start"], m["goal"], cfg=cfg, distance=m["distance"])
        return build_priors("NDR-QL", m["bblocked"], m["start"], m["goal"], m["region"], m["guideline"], cfg,
                            m["distance"], threshold=None)


def map_steps(row: str, m: dict, ql: QLConfig, cfg: PriorConfig, seeds) -> list[int]:
    pri = priors_of(row, m, cfg)
    method = "NDR-QL" if row == "NDR-QL" else "IQL-BFS"  # the kernel's method: IQL-NDR learns as IQL-BFS does
    return [steps_of(run_plan(m["blocked"], m["start"], m["goal"], method, s, ql, priors=pri)) for s in seeds]


def serves(preset, n: int) -> int:
    """The grid entry of ``preset`` a map planned on ``n`` cells takes (the nearest, as ``plan``): a map of the grid-50
    setting planned on 80 cells (the truth connects only there) takes grid 100's constants."""
    return nearest_grid(sorted(preset.grids), n)


def split(maps: list[dict], half: str) -> list[dict]:
    """``all``, or a half by index parity (``search`` = even, else odd): on a set that cycles through its twelve
    families, parity splits the families too (studies/partial/README.md, "The fourth round")."""
    return maps if half == "all" else [m for m in maps if m["index"] % 2 == (0 if half == "search" else 1)]


def lift(data: dict, method: str = "NDR-QL", top: int | None = None) -> dict:
    """A preset file's ``method`` entry at its largest searched grid copied to every larger grid (the entries above
    100 cells were never searched on beliefs); ``data`` is changed and returned."""
    if top is None:  # a preset file's own record of its searched grids
        top = max([int(g) for g in data.get("meta", {}).get("searched", {}).get("grids", {})] or [100])
    for g, entries in data["grids"].items():
        if int(g) > top:
            entries[method] = json.loads(json.dumps(data["grids"][str(top)][method]))
    return data


def configs(params: dict, base_ql: QLConfig, base_pri: PriorConfig, space) -> tuple[QLConfig, PriorConfig]:
    ql, pri = {}, {}
    for p in space:
        for f in p.fields:
            (ql if p.part == "ql" else pri)[f] = float(params[p.name])
    return replace(base_ql, **ql), replace(base_pri, **pri)


def params_of(ql: QLConfig, pri: PriorConfig, space) -> dict:
    return {p.name: float(min(max(getattr(ql if p.part == "ql" else pri, p.fields[0]), p.low), p.high)) for p in space}


# --- the search ----------------------------------------------------------------------------------------------


def search(args, grid: int) -> int:
    import optuna

    preset = load_preset(args.preset)
    maps = [m for m in split(with_distance(args, build_cache(args, grid), grid), "search" if args.half == "even" else "all")
            if serves(preset, m["n"]) == grid]
    order = np.random.default_rng(args.order_seed).permutation(len(maps))
    maps = [maps[i] for i in order]
    chunks = np.array_split(np.arange(len(maps)), args.chunks)
    row = args.method
    ql0, pri0 = preset.configs(row, grid=grid)
    qli, prii = preset.configs("IQL-BFS", grid=grid)
    space = SPACE[row]
    seeds = list(range(args.search_seeds))
    cap = dict(max_episodes=args.max_episodes)
    log = Path(args.out) / f"trials-{row}-g{grid}{args.tag}.jsonl"
    log.parent.mkdir(parents=True, exist_ok=True)

    def objective(trial) -> float:
        params = {p.name: trial.suggest_float(p.name, p.low, p.high, log=p.log) for p in space}
        ql, pri = configs(params, ql0, pri0, space)
        ql = replace(ql, **cap)
        logs = []
        t0 = time.perf_counter()
        for k, ids in enumerate(chunks):
            for i in ids:
                m = maps[i]
                steps = map_steps(row, m, ql, pri, seeds)
                logs.append(math.log(np.mean(steps) / np.mean([m["ref"][s] for s in seeds])))
            value = float(np.exp(np.mean(logs)))
            trial.report(value, k)
            if trial.should_prune():
                _log(log, trial.number, params, value, len(logs), "pruned", time.perf_counter() - t0)
                raise optuna.TrialPruned()
        _log(log, trial.number, params, value, len(logs), "done", time.perf_counter() - t0)
        return value

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(direction="minimize", sampler=optuna.samplers.TPESampler(seed=args.sampler_seed),
                                pruner=optuna.pruners.MedianPruner(n_startup_trials=8, n_warmup_steps=0)
                                if args.chunks > 1 else optuna.pruners.NopPruner())
    study.enqueue_trial(params_of(ql0, pri0, space))  # the preset's own entry
    if row == "NDR-QL":
        study.enqueue_trial(params_of(qli, replace(pri0, r_max=prii.r_max, g_row=prii.g_row, g_col=prii.g_col), space))
    study.optimize(objective, n_trials=args.trials, timeout=args.timeout)
    best = study.best_trial
    ql, pri = configs(best.params, ql0, pri0, space)
    res = {"method": row, "grid": grid, "set": args.set, "belief": f"{args.kind}:{args.fraction:g}",
           "weights": str(resolve_weights(args.weights)), "half": "search (even indices)" if args.half == "even" else "all", "maps": len(maps),
           "seeds": seeds, "max_episodes": args.max_episodes, "trials": len(study.trials),
           "pruned": sum(t.state.name == "PRUNED" for t in study.trials), "sampler_seed": args.sampler_seed,
           "first_trial": study.trials[0].value, "best_trial": best.number, "best_value": best.value,
           "ql": {k: getattr(ql, k) for k in ("alpha", "epsilon", "gamma")},
           "priors": {k: getattr(pri, k) for k in ("r_max", "g_row", "g_col", "omega_crf", "omega_qi", "guideline_ties")}}
    write_json(Path(args.out) / f"best-{row}-g{grid}{args.tag}.json", res, indent=2)
    print(json.dumps(res, indent=1))
    return 0


def _log(path: Path, number: int, params: dict, value: float, maps: int, state: str, seconds: float) -> None:
    with path.open("a") as f:
        f.write(json.dumps({"trial": number, "state": state, "value": value, "maps": maps,
                            "seconds": round(seconds, 1), "params": params}) + "\n")
    print(f"trial {number} {state} {value:.4f} on {maps} maps ({seconds:.0f} s)", flush=True)


# --- the check -----------------------------------------------------------------------------------------------


def check(args, grid: int) -> int:
    """Every row on the check half (and ``--both``: the search half) with seeds 0-2, each map with the constants of
    the entry its planning size takes (:func:`serves`, as ``plan``); one JSON line per map."""
    general = load_preset(args.preset)
    presets = {"NDR-QL (belief preset)": ("NDR-QL", preset_from_dict(candidate(args), "candidate"))}
    if args.check_set:  # the shipped preset beside the candidate, as it is and with 100's entry above 100 cells
        from ndrql.planning.preset import builtin_path

        shipped = json.loads(builtin_path("belief").read_text())
        presets["NDR-QL (shipped belief)"] = ("NDR-QL", preset_from_dict(shipped, "shipped"))
        presets["NDR-QL (shipped belief, lifted)"] = ("NDR-QL", preset_from_dict(lift(shipped), "shipped-lifted"))
    if any((Path(args.out) / f"best-IQL-BFS-g{g}{args.tag}.json").exists() for g in args.grids.split(",")):
        presets["IQL-BFS (searched)"] = ("IQL-BFS", preset_from_dict(candidate(args, "IQL-BFS", "iql-bfs"), "candidate"))

    def rows_of(n: int) -> dict:
        qln, prin = general.configs("NDR-QL", grid=n)
        qli, prii = general.configs("IQL-BFS", grid=n)
        out = {"NDR-QL (general)": ("NDR-QL", qln, prin),
               "NDR-QL (IQL constants)": ("NDR-QL", qli, replace(prin, r_max=prii.r_max, g_row=prii.g_row, g_col=prii.g_col,
                                                                  omega_crf=prii.omega_crf, omega_qi=prii.omega_qi,
                                                                  guideline_ties=prii.guideline_ties)),
               "IQL-NDR": ("IQL-NDR", *general.configs("IQL-NDR", grid=n))}
        for name, (row, p) in presets.items():
            out[name] = (row, *p.configs(row, grid=n))
        return out

    other = f"-{args.check_set}" if args.check_set else ""
    out = Path(args.out) / f"check-g{grid}{args.tag}{other}.jsonl"
    done = {json.loads(x)["index"] for x in out.read_text().splitlines()} if out.exists() else set()
    maps = build_cache(argparse.Namespace(**{**vars(args), "set": args.check_set or args.set}), grid)
    halves = [m for m in maps if m["index"] % 2 == 1 or args.check_set] + (
        [m for m in maps if m["index"] % 2 == 0] if args.both and not args.check_set else [])
    with out.open("a") as f:
        for m in halves:
            if m["index"] in done:
                continue
            rec = {"index": m["index"], "family": m["family"], "grid": grid, "n": m["n"], "entry": serves(general, m["n"]),
                   "half": "check" if m["index"] % 2 or args.check_set else "search", "rows": {"IQL-BFS (belief)": m["ref"]}}
            for name, (row, ql, pri) in rows_of(m["n"]).items():
                rec["rows"][name] = map_steps(row, m, ql, pri, SEEDS)
            f.write(json.dumps(rec) + "\n")
            f.flush()
    return 0


def report(folder: str) -> int:
    ref = "IQL-BFS (belief)"
    for path in sorted(Path(folder).glob("check-g*.jsonl")):
        recs = [json.loads(x) for x in path.read_text().splitlines() if x.strip()]
        for half in ("search", "check"):
            group = [r for r in recs if r["half"] == half]
            if not group:
                continue
            print(f"\n{path.name}, {half} half: {len(group)} maps")
            for name in group[0]["rows"]:
                if name == ref:
                    continue
                a, b = [np.mean(r["rows"][name]) for r in group], [np.mean(r["rows"][ref]) for r in group]
                g = geomean_ratio(a, b)
                o = outcomes([r["rows"][name] for r in group], [r["rows"][ref] for r in group])
                fams = sorted({r["family"] for r in group})
                worst = max((geomean_ratio([np.mean(r["rows"][name]) for r in group if r["family"] == fa],
                                           [np.mean(r["rows"][ref]) for r in group if r["family"] == fa])["ratio"], fa)
                            for fa in fams)
                print(f"| {name} | {g['ratio']:.3f} ({g['low']:.2f} .. {g['high']:.2f}) | {o['wins']}/{o['ties']}/"
                      f"{o['losses']} | {worst[1]} {worst[0]:.2f} |")
            base = "NDR-QL (general)"
            for name in [x for x in group[0]["rows"] if x.endswith(("(belief preset)", "(searched)"))]:
                other = base if name.startswith("NDR-QL") else ref
                g = geomean_ratio([np.mean(r["rows"][name]) for r in group], [np.mean(r["rows"][other]) for r in group])
                o = outcomes([r["rows"][name] for r in group], [r["rows"][other] for r in group])
                print(f"  {name} / {other}: {g['ratio']:.3f} ({g['low']:.2f} .. {g['high']:.2f}) W/T/L {o['wins']}/"
                      f"{o['ties']}/{o['losses']}")
    return 0


def candidate(args, method: str = "NDR-QL", name: str = "belief") -> dict:
    """General's preset file with ``method``'s entries at ``--grids`` replaced by the searches' constants (every other
    method and grid, and the fields the search does not set, general's)."""
    from ndrql.planning.preset import builtin_path

    data = json.loads(builtin_path("general").read_text())
    searched = {}
    for grid in (int(g) for g in args.grids.split(",")):
        f = Path(args.out) / f"best-{method}-g{grid}{args.tag}.json"
        if not f.exists():
            continue
        b = json.loads(f.read_text())
        entries = data["grids"][str(grid)]
        base = entries.get(method) or entries[method.replace("-BFS", "")]  # IQL-BFS starts from IQL's entry
        entry = json.loads(json.dumps(base))
        entry["ql"].update(b["ql"])
        entry["priors"].update(b["priors"])
        entries[method] = entry
        searched[str(grid)] = {k: b[k] for k in ("set", "belief", "half", "maps", "seeds", "max_episodes", "trials",
                                                 "sampler_seed", "best_trial", "best_value", "first_trial")}
        searched[str(grid)]["weights"] = Path(b["weights"]).name
    if args.above and searched:
        lift(data, method, max(int(g) for g in searched))
    data["name"] = name
    data["plan_default"] = True
    data["meta"] = {"from": "general", "searched": {"method": method, "grids": searched,
                                                    "objective": "geomean of NDR-QL / IQL-BFS (belief) mean steps",
                                                    "script": "studies/partial/tune_belief.py"},
                    "check": args.check_note, "above": "the top searched grid's entry at every larger grid"
                    if args.above else "general's entries above the searched grids", "why": "plan's preset on a belief map (--hide): NDR-QL's constants "
                    "searched there; IQL and IQL-BFS keep general's, so the reference IQL-BFS (belief) is unchanged"}
    return data


def write_belief_preset(args) -> int:
    """``--preset-out`` (default ``src/ndrql/planning/presets/belief.json``): :func:`candidate`."""
    data = candidate(args)
    if args.with_reference:  # IQL-BFS's searched entries too (the rule's reference, when they won the check)
        ref = candidate(args, "IQL-BFS", "iql-bfs")
        for g, entries in data["grids"].items():
            entries["IQL-BFS"] = ref["grids"][g].get("IQL-BFS", entries.get("IQL-BFS"))
        data["meta"]["reference"] = {"method": "IQL-BFS", "grids": ref["meta"]["searched"]["grids"]}
        data["meta"]["why"] = ("plan's preset on a belief map (--hide): NDR-QL's and IQL-BFS's constants searched "
                               "there (IQL-BFS's won the check at both grids); every other method keeps general's")
    target = Path(args.preset_out)  # a file of the package: write_json refuses those, so a plain atomic replace
    tmp = target.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    tmp.replace(target)
    print(f"wrote {target}")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--weights", default=BELIEF_WEIGHTS, help="belief model (default: the shipped belief weights)")
    ap.add_argument("--set", default="partial-dev-b")
    ap.add_argument("--kind", default="blobs")
    ap.add_argument("--fraction", type=float, default=0.3)
    ap.add_argument("--grid", type=int, default=50)
    ap.add_argument("--preset", default="general")
    ap.add_argument("--method", default="NDR-QL", choices=sorted(SPACE))
    ap.add_argument("--trials", type=int, default=200)
    ap.add_argument("--timeout", type=float, default=None, help="seconds of search at most")
    ap.add_argument("--search-seeds", type=int, default=3)
    ap.add_argument("--max-episodes", type=int, default=3000, help="cap of a search run (not converged: every step)")
    ap.add_argument("--chunks", type=int, default=1, help="Optuna's MedianPruner over this many chunks of maps (1: none)")
    ap.add_argument("--sampler-seed", type=int, default=0)
    ap.add_argument("--order-seed", type=int, default=0)
    ap.add_argument("--distance", default="model", help="NDR-QL's goal distance: model, geo:k or maxgeo:k (geodesic.py)")
    ap.add_argument("--tag", default="", help="suffix of the output files (e.g. a weights' name)")
    ap.add_argument("--out", default="results/partial/tune_belief")
    ap.add_argument("--check", action="store_true", help="evaluate the rows on the check half (and --both: search half)")
    ap.add_argument("--both", action="store_true")
    ap.add_argument("--half", default="even", choices=("even", "all"), help="the search's maps: the even half or all")
    ap.add_argument("--check-set", default=None, help="check on every map of this set (with the shipped preset's rows)")
    ap.add_argument("--above", action="store_true", help="the top searched grid's entry also at every larger grid")
    ap.add_argument("--with-reference", action="store_true", help="--write-preset: IQL-BFS's searched entries too")
    ap.add_argument("--cache-only", action="store_true")
    ap.add_argument("--report", default=None)
    ap.add_argument("--all", action="store_true", help="search every --grids grid, check both halves, report")
    ap.add_argument("--write-preset", action="store_true", help="write the belief preset from --grids' searches")
    ap.add_argument("--grids", default="50,100")
    ap.add_argument("--preset-out", default="src/ndrql/planning/presets/belief.json")
    ap.add_argument("--check-note", default="", help="the check half's result, recorded in the preset's meta")
    args = ap.parse_args(argv)
    if args.report:
        return report(args.report)
    if args.write_preset:
        return write_belief_preset(args)
    if args.all:  # the whole study in one command: search each grid, then check both halves, then the report
        for grid in (int(g) for g in args.grids.split(",")):
            search(args, grid)
        for grid in (int(g) for g in args.grids.split(",")):
            args.both = True
            check(args, grid)
        return report(args.out)
    if args.cache_only:
        build_cache(args, args.grid)
        return 0
    return check(args, args.grid) if args.check else search(args, args.grid)


if __name__ == "__main__":
    sys.exit(main())
