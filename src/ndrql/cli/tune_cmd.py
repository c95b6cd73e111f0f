"""``ndrql tune``: search a method's constants on held-out TRAIN maps (Optuna, seeded TPE), or
collect the searches into a preset."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from ndrql.cli.common import add_weights_argument, check_outputs
from ndrql.cli.options import add_command
from ndrql.dataset.layout import resolve_root
from ndrql.errors import NdrqlError
from ndrql.io.readset import in_package
from ndrql.limits import MAX_GRID_SIZE, MIN_GRID_SIZE, MAX_RUNS, MAX_WORKERS, SEED_LIMIT, check_int
from ndrql.model.weights import PAPER_WEIGHTS
from ndrql.planning import compiled
from ndrql.planning.methods import get_method
from ndrql.planning.preset import Preset, load_preset, write_preset
from ndrql.tuning import space as S
from ndrql.tuning.objective import tuning_problems
from ndrql.tuning.report import check_presets, trial_setting, tuned_preset, write_study_outputs
from ndrql.tuning.study import TuneConfig, base_score, best_trial, best_trials, default_storage, finished, open_storage, run_study, study_name
from ndrql.workers import process_pool

EXAMPLES = """examples:
  ndrql tune --method NDR-QL                          # 200 trials, 100 validation maps x 10 seeds -> results/tune/
  ndrql tune --method NDR-QL --maps generated --grid 100 --weights general   # held-out generated maps, 100x100 grids
  ndrql tune --method QL --trials 20 --samples 10     # a small search
  ndrql tune --method IQL --storage sqlite:////shared/studies.db   # several processes or machines, one study
  ndrql tune --export-preset tuned.json --methods QL,O-QL,IQL,NDR-QL   # best trials -> a preset file
  ndrql tune --export-preset general.json --maps generated --grids 50,100 --weights general   # one entry per grid

--maps paper (default): only the TRAIN maps the shipped model did not train on (its validation
split) are used; TEST is never read. --maps generated: the versioned evaluation set 'tune' of
generated maps of every family (a seed no training set and no reported set uses), on the safe grid
of --grid cells, problems taken family by family in turn; the objective is then the geometric mean
of the steps (every map weighs alike) unless --objective says otherwise. A killed search continues where it stopped when run again with the same settings.
Use the result with --preset FILE on plan, demo and reproduce.
"""


def register(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "tune", help="search a planner's constants on validation maps (needs ndrql[tune])",
                    description=__doc__, examples=EXAMPLES)
    p.add_argument("--method", metavar="NAME", help="method to tune (QL, D-C, N-C, D-Q, N-Q, IQL, O-QL, NDR-QL, IQL-BFS, IQL-NDR)")
    p.add_argument("--trials", type=int, default=200, metavar="N", help="finished trials per method, the spec "
                   "preset's point included (default: 200)")
    p.add_argument("--samples", type=int, default=100, metavar="K", help="validation maps per evaluation (default: 100)")
    p.add_argument("--maps", choices=("paper", "generated"), default="paper",
                   help="paper: the model's validation split of the paper's TRAIN maps on 50x50 grids (default); "
                   "generated: the held-out generated set 'tune' on the safe grid of --grid cells")
    p.add_argument("--eval-set", metavar="NAME", default="tune", help="--maps generated: the versioned set of generated "
                   "maps to search on (default: tune; the development report 'transfer', the 'select' set and every sealed set "
                   "are refused)")
    p.add_argument("--grid", type=int, default=50, metavar="N", help="--maps generated: planning grid size (default: 50)")
    p.add_argument("--grids", metavar="LIST", default="50,100",
                   help="--maps generated with --export-preset: the grid sizes whose studies the preset collects, "
                   "one entry each (default: 50,100)")
    p.add_argument("--start-from", metavar="PRESET", default="",
                   help="make trial 1 this preset's constants for the method (spec, tuned, general or a FILE; of a "
                   "per-grid preset, the searched grid's entry), so the search starts from the best point known, and "
                   "hold the preset's constants that no search explores (--guideline-ties, --region-dilation, "
                   "--region-distance, --thd-tail) in every trial and in the export (default: none)")
    p.add_argument("--objective", choices=("pooled", "geomean"),
                   help="minimise the pooled mean of the steps or their geometric mean (default: pooled with "
                   "--maps paper, geomean with --maps generated)")
    p.add_argument("--seeds", type=int, default=10, metavar="S", help="Q-learning seeds per map, 0..S-1 (default: 10)")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the TPE sampler (default: 0)")
    p.add_argument("--order-seed", type=int, default=0, metavar="N",
                   help="seed of the order validation maps are drawn in (default: 0)")
    p.add_argument("--max-episodes", type=int, default=3000, metavar="N",
                   help="episode cap of a run during the search; a trial with a run over it is pruned (default: 3000)")
    p.add_argument("--chunk", type=int, default=10, metavar="N", help="maps between pruning checks (default: 10)")
    p.add_argument("--storage", metavar="URL", help="Optuna storage URL shared by several processes or machines "
                   "(default: sqlite under --out)")
    p.add_argument("--study-name", metavar="NAME", help="study name (default: METHOD-<digest of the settings>)")
    p.add_argument("--out", metavar="DIR", default="results/tune", help="results directory (default: results/tune)")
    p.add_argument("--data", metavar="DIR", help="dataset root (default: $NDRQL_DATASET, else a path-planning-dataset folder in the working directory)")
    add_weights_argument(p, PAPER_WEIGHTS)
    p.add_argument("--workers", type=int, default=2, metavar="N", help="processes running a trial's maps (default: 2)")
    p.add_argument("--export-preset", metavar="FILE", help="instead of searching: write the best trials of the "
                   "--methods' studies as a preset file, after checking them against spec on fresh seeds")
    p.add_argument("--methods", metavar="LIST", default="QL,O-QL,IQL,NDR-QL",
                   help="--export-preset: methods to collect (default: QL,O-QL,IQL,NDR-QL)")
    p.add_argument("--candidates", type=int, default=1, metavar="N",
                   help="--export-preset: when a method's best feasible trial does not win its check on fresh seeds, "
                   "check its next best in order, up to N trials in all, and adopt the first that wins (default: 1, "
                   "the best only)")
    p.add_argument("--keep-from", metavar="PRESET", default="",
                   help="--export-preset with --maps generated: methods not in --methods keep this per-grid "
                   "preset's constants and provenance (e.g. re-search NDR-QL alone for new weights), and grids not in --grids "
                   "keep their entries whole (e.g. add a grid-256 entry: --grids 256 --keep-from general)")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    p.set_defaults(func=run)


def _tune_config(args: argparse.Namespace, method: str, grid: int):
    """The search of ``method`` on grid ``grid``; with ``--start-from`` it also holds that preset's constants
    outside the search space (its route ties) for the method and grid."""
    check_int(args.trials, "--trials", 1, 100_000)
    check_int(args.samples, "--samples", 1, 12_000)
    check_int(args.seeds, "--seeds", 1, MAX_RUNS)
    check_int(args.seed, "--seed", 0, SEED_LIMIT - 1)
    check_int(args.order_seed, "--order-seed", 0, SEED_LIMIT - 1)
    check_int(args.max_episodes, "--max-episodes", 1, 1_000_000)
    check_int(args.chunk, "--chunk", 1, 12_000)
    objective = args.objective or ("geomean" if args.maps == "generated" else "pooled")
    return TuneConfig(method, trials=args.trials, samples=args.samples, seeds=args.seeds, seed=args.seed,
                      order_seed=args.order_seed, chunk=args.chunk, max_episodes=args.max_episodes, objective=objective,
                      start_from=args.start_from, grid=grid, fixed=_fixed(args.start_from, method, grid))


def _fixed(start_from: str, method: str, grid: int) -> tuple[tuple[str, float], ...]:
    """The constants outside the search space that ``start_from`` sets for ``method`` on ``grid`` (none without)."""
    return S.fixed_priors(load_preset(start_from).configs(method, grid=grid)[1]) if start_from else ()


def _grids(args: argparse.Namespace) -> list[int]:
    """The grid sizes this call works on: ``--grids`` when exporting generated-map studies, else ``--grid``."""
    if args.maps != "generated":
        return [50]
    if not args.export_preset:
        check_int(args.grid, "--grid", MIN_GRID_SIZE, MAX_GRID_SIZE)
        return [args.grid]
    try:
        sizes = [int(x) for x in args.grids.split(",") if x.strip()]
    except ValueError:
        raise NdrqlError(f"--grids must be grid sizes separated by commas, got {args.grids!r}") from None
    if not sizes:
        raise NdrqlError("--grids is empty")
    for n in sizes:
        check_int(n, "--grids", MIN_GRID_SIZE, MAX_GRID_SIZE)
    return sorted(set(sizes))


def _problems(args: argparse.Namespace, n: int, log) -> tuple[list, str]:
    """The search's problems on grid ``n`` and the weights' digest (``--maps``)."""
    if args.maps == "generated":
        from ndrql.experiments.tune_maps import generated_problems  # lazy: loads the model stack

        problems, skipped, digest = generated_problems(args.samples, n, args.weights, args.eval_set,
                                                       progress=not args.no_progress)
        log(f"generated maps: {len(problems)} problems of set {args.eval_set!r} on the safe grid of {n} cells (or the "
            f"next ladder size), family by family ({len(skipped)} maps disconnected on every size); "
            f"seeds 0..{args.seeds - 1}")
        return problems, digest
    root = resolve_root(args.data)
    problems, skipped, digest = tuning_problems(root, args.samples, args.order_seed, args.weights,
                                                progress=not args.no_progress)
    log(f"validation maps: {len(problems)} TRAIN samples of the model's validation split "
        f"({len(skipped)} skipped as disconnected on the planning grid); seeds 0..{args.seeds - 1}")
    return problems, digest


def _need_optuna() -> None:
    try:
        import optuna  # noqa: F401
    except ImportError:
        raise NdrqlError("ndrql tune needs Optuna: pip install 'ndrql[tune]' (or pip install optuna)") from None


#: Optuna storage URL schemes (SQLAlchemy dialects, with or without a driver: ``postgresql+psycopg2://``).
STORAGE_SCHEMES = ("sqlite", "postgresql", "mysql")


def check_storage(url: str | None) -> None:
    """``--storage``: an SQL URL Optuna can open (``sqlite:///FILE``, ``postgresql://...``, ``mysql://...``)."""
    if url is None:
        return
    shown = url[:60] if url[:60].isprintable() else repr(url[:60])
    scheme = url.split("://", 1)[0].split("+", 1)[0].lower() if "://" in url else ""
    if scheme not in STORAGE_SCHEMES:
        raise NdrqlError(f"--storage must be an SQL database URL ({', '.join(s + '://...' for s in STORAGE_SCHEMES)}), "
                         f"got {shown}")
    if scheme == "sqlite":
        path = url.split("://", 1)[1][1:]  # sqlite:///relative or sqlite:////absolute
        if path and path != ":memory:":
            folder = os.path.dirname(os.path.abspath(path))
            if not os.path.isdir(folder):
                raise NdrqlError(f"--storage {shown}: the folder {folder} does not exist")
            check_sqlite_file(path, f"--storage {shown}")


def check_sqlite_file(path: str, flag: str) -> None:
    """An SQLite storage file is written in place by SQLite, not by ndrql's writer: refuse a folder, a symlink,
    a file the package ships and any existing file that is not an SQLite database (a map, a checkpoint)."""
    if os.path.islink(path) or os.path.isdir(path) or in_package(path):
        what = "a symbolic link" if os.path.islink(path) else "a folder" if os.path.isdir(path) else \
            "inside the installed ndrql package"
        raise NdrqlError(f"{flag}: {path} is {what}; give an SQLite file (it is created when missing)")
    if os.path.isfile(path) and os.path.getsize(path) > 0:
        with open(path, "rb") as fh:
            if fh.read(16) != b"SQLite format 3\0":
                raise NdrqlError(f"{flag}: {path} is not an SQLite database; nothing was written, give another file")


def run(args: argparse.Namespace) -> int:
    check_int(args.workers, "--workers", 1, MAX_WORKERS)
    if args.export_preset is None and not args.method:
        raise NdrqlError("give --method NAME (or --export-preset FILE)")
    methods = [get_method(m.strip()).name for m in args.methods.split(",") if m.strip()] if args.export_preset \
        else [get_method(args.method).name]
    if not methods:
        raise NdrqlError("--methods is empty")
    check_storage(args.storage)  # before the maps are built: a bad URL is one line now
    if not args.storage and args.out:
        check_sqlite_file(os.path.join(args.out, "studies.db"), f"--out {args.out}")
    if args.start_from:
        load_preset(args.start_from)  # an unknown preset is one line now, not after the maps are built
    if args.maps == "generated":
        from ndrql.experiments.eval_sets import tuning_spec  # lazy: loads scipy

        tuning_spec(args.eval_set)  # a sealed set, or one that reports or checks, is one line now
    grids = _grids(args)
    cfgs = [_tune_config(args, m, grids[0]) for m in methods]
    if args.export_preset:
        check_outputs(args.export_preset)
    _need_optuna()
    storage = args.storage or default_storage(args.out)
    log = lambda msg: print(msg, file=sys.stderr)  # noqa: E731
    if args.export_preset:
        if args.maps == "generated":
            return _export_grids(args, cfgs, grids, storage, log)
        problems, digest = _problems(args, 50, log)
        return _export(args, cfgs, problems, storage, digest, log)

    problems, digest = _problems(args, grids[0], log)
    cfg = cfgs[0]
    study = run_study(cfg, problems, storage, digest, workers=args.workers, progress=not args.no_progress,
                      name=args.study_name)
    folder = write_study_outputs(study, cfg, args.out)
    bt = best_trial(study)
    base = study.user_attrs["baseline"]
    print(f"{cfg.method}: study {study.study_name} in {storage}")
    what = "steps per run" if cfg.objective == "pooled" else "steps per run (geometric mean)"
    print(f"spec preset: {base_score(base, cfg):,.0f} {what}, greedy path / A* {base['ratio']:.3f}")
    if bt is not None:
        print(f"best trial {bt.number}: {bt.value:,.0f} {what} ({1 - bt.value / base_score(base, cfg):.0%} fewer), "
              f"greedy path / A* {bt.user_attrs.get('ratio', float('nan')):.3f}")
        print("constants: " + ", ".join(f"{k} {v:.4g}" for k, v in bt.params.items()))
    print(f"wrote {folder}/best.json, trials.json, history.png, importance.png")
    return 0


def _export(args, cfgs, problems, storage, digest, log) -> int:
    settings, check, meta = _collect(args, cfgs, problems, storage, digest, log)
    preset = tuned_preset(settings, check, meta)
    path = write_preset(args.export_preset, preset)
    print(f"wrote {path} (plan default: {'tuned' if preset.plan_default else 'spec'})")
    return 0


def _export_grids(args, cfgs, grids, storage, log) -> int:
    """A preset with one entry per grid size, each from that grid's studies (``--maps generated``)."""
    entries, metas, wins = {}, {}, []
    for n in grids:
        problems, digest = _problems(args, n, log)
        at_n = [_tune_config(args, c.method, n) for c in cfgs]  # fixed constants and trial 1 are per grid
        settings, check, meta = _collect(args, at_n, problems, storage, digest, log)
        entry = tuned_preset(settings, check, meta)
        entries[n], metas[str(n)] = dict(entry.methods), dict(entry.meta)
        wins.append(entry.plan_default)
    if args.keep_from:
        entries, metas = kept_entries(load_preset(args.keep_from), entries, metas)
    name = Path(args.export_preset).stem
    preset = Preset(name=name, grids=entries, plan_default=all(wins),
                    meta={"maps": "generated", "objective": cfgs[0].objective, "grids": metas})
    path = write_preset(args.export_preset, preset)
    print(f"wrote {path} (grids {', '.join(map(str, grids))}; plan default for its weights: "
          f"{'yes' if preset.plan_default else 'no'})")
    return 0


def kept_entries(base: Preset, entries: dict, metas: dict) -> tuple[dict, dict]:
    """Per grid: ``base``'s methods and provenance, with the newly searched methods of ``entries`` /
    ``metas`` replacing theirs (their search settings under ``meta["search_by_method"]``, since the
    weights digest may differ from the kept methods' search). A grid of ``base`` the export did not search
    is kept whole; a grid ``base`` lacks is added with the searched methods alone (the others keep taking
    the nearest entry that lists them, :meth:`Preset.setting`) and with the search's settings and check seeds
    as its own provenance."""
    base_metas = dict(base.meta).get("grids", {})
    out_e = {n: dict(base.grids[n]) for n in base.grids}
    out_m = {str(n): dict(base_metas.get(str(n), {})) for n in base.grids}
    for n, new in entries.items():
        old_meta = dict(base_metas.get(str(n), {}))
        meta = {**old_meta, "studies": {**old_meta.get("studies", {}), **metas[str(n)]["studies"]},
                "validation_check": {**old_meta.get("validation_check", {}), **metas[str(n)]["validation_check"]},
                "search_by_method": {**old_meta.get("search_by_method", {}),
                                     **{m: metas[str(n)]["search"] for m in new}}}
        kept = [m for m in old_meta.get("kept_spec", []) if m not in new] + list(metas[str(n)]["kept_spec"])
        meta["kept_spec"] = kept
        if str(n) not in base_metas:  # a new grid: its search is the grid's provenance (tools/preset_path_check.py)
            meta.update({k: metas[str(n)][k] for k in ("search", "check_seeds") if k in metas[str(n)]})
        out_e[n] = {**dict(base.grids.get(n, {})), **new}
        out_m[str(n)] = meta
    return dict(sorted(out_e.items())), dict(sorted(out_m.items(), key=lambda kv: int(kv[0])))


def _collect(args, cfgs, problems, storage, digest, log):
    """Each method's best trial on ``problems``, its check against spec on fresh seeds, and the provenance."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.ERROR)  # errors reach ndrql's one door
    settings, studies, alternates, trials = {}, {}, {}, {}
    for cfg in cfgs:
        name = study_name(cfg, [p.key for p in problems], digest)
        try:
            study = optuna.load_study(study_name=name, storage=open_storage(storage, cfg))
        except KeyError:
            raise NdrqlError(f"no study {name} for {cfg.method} in {storage}: run ndrql tune --method "
                             f"{cfg.method} with the same settings first") from None
        ranked = best_trials(study, max(1, args.candidates))
        fixed = cfg.base_configs()[1]
        bt = ranked[0] if ranked else None
        settings[cfg.method] = trial_setting(bt, fixed)
        alternates[cfg.method] = [trial_setting(t, fixed) for t in ranked[1:]]
        trials[cfg.method] = ranked
        studies[cfg.method] = {"study": name, "finished_trials": finished(study), "best_trial": bt.number if bt else None,
                               "best_steps": bt.value if bt else None, "baseline": study.user_attrs.get("baseline")}
        log(f"{cfg.method}: best trial {bt.number if bt else '-'} of {finished(study)}"
            + (f" (then up to {len(ranked) - 1} next best if it does not win)" if len(ranked) > 1 else ""))
    cfg = cfgs[0]
    check_seeds = list(range(cfg.seeds, 2 * cfg.seeds))
    compiled.warm_up()
    with process_pool(args.workers, start_method="fork") as pool:
        check = check_presets(problems, [c.method for c in cfgs], settings, check_seeds, pool, cfg.objective,
                              alternates=alternates)
    key = "geomean" if cfg.objective == "geomean" else "steps"
    for m, c in check.items():
        if c["candidate"]:  # a next-best trial won where the best did not: adopt it, and say so
            settings[m] = alternates[m][c["candidate"] - 1]
            adopted = trials[m][c["candidate"]]
            studies[m].update(adopted_trial=adopted.number, adopted_steps=adopted.value, candidates_checked=c["candidates_checked"])
            log(f"{m}: the best trial did not win its check; trial {adopted.number} (rank {c['candidate'] + 1}) did")
        log(f"{m}: fresh seeds {check_seeds[0]}..{check_seeds[-1]}: spec {c['spec'][key]:,.0f} steps "
            f"(path/A* {c['spec']['ratio']:.3f}), tuned {c['tuned'][key]:,.0f} ({c['tuned']['ratio']:.3f}, "
            f"paired difference {c['ratio_difference']['mean']:+.4f} +- {c['ratio_difference']['se']:.4f}); "
            f"{'tuned wins' if c['tuned_wins'] else 'tuned does not win'}")
    meta = {"search": {"samples": len(problems), "seeds": cfg.seed_list, "trials": cfg.trials,
                       "max_episodes": cfg.max_episodes, "sampler_seed": cfg.seed, "order_seed": cfg.order_seed,
                       "weights_sha256_16": digest, "problems": [p.key for p in problems], "objective": cfg.objective,
                       **({"eval_set": args.eval_set} if args.maps == "generated" else {})},
            "studies": studies, "check_seeds": check_seeds}
    return settings, check, meta
