"""``ndrql reproduce TARGET``: regenerate the paper's tables and figures (and the ``scale`` study)."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from ndrql.cli.common import add_symmetries_argument, add_weights_argument
from ndrql.cli.options import add_command, add_config_flags, add_seed_options, configs_from_flags
from ndrql.errors import NdrqlError, require_torch
from ndrql.experiments.labels_check import labels_check
from ndrql.experiments.presets import run_presets
from ndrql.limits import MAX_WORKERS, check_int, check_seeds
from ndrql.model.symmetry import DEFAULT_COUNT
from ndrql.model.weights import PAPER_WEIGHTS
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.preset import builtin_path, load_preset, plan_default_preset
from ndrql.synth.oracle import PRIOR_SOURCES
from ndrql.workers import ray_available

TARGETS = ("table1", "table2", "table3", "table4", "dynamic", "scale", "sizing", "labels", "transfer", "release", "partial",
           "all")

EXAMPLES = """examples:
  ndrql reproduce table3                       # 8 fixed maps x QL, O-QL, IQL, NDR-QL x 10 seeds -> results/table3/
  ndrql reproduce table2 --seeds 10 --workers 2
  ndrql reproduce scale --per-category 50      # 200 SEEN + 200 UNSEEN samples, 10 seeds each
  ndrql reproduce table3 --executor ray        # same table, runs on a local Ray instance (pip install 'ndrql[ray]')
  ndrql reproduce table4 --run --epochs 2      # trains every Table 4 variant (resumable), then evaluates them
  ndrql reproduce sizing                       # validation F1 per training hour by width and precision
  ndrql reproduce labels --limit 200           # our labels and endpoints against the dataset's (TEST/SEEN)
  ndrql reproduce transfer --grids 50,100      # the development set of generated maps: every row, every family
  ndrql reproduce transfer --preset spec --no-learned-distance   # the paper's Eq. 6 (straight line) with the general weights
  ndrql reproduce release                      # the sealed set at grids 50 and 100, once per release (counted in the ledger)
  ndrql reproduce release --eval-set sealed-large-256 --seeds 3   # a large sealed set, at its own grid (256); no QL rows above 100 cells
  ndrql reproduce partial --grids 50 --limit 4 --seeds 1 --beliefs blobs:0.3 --sense off   # belief maps: a quick look
  ndrql reproduce partial --seeds 3            # partial-dev: blobs 10/30/50%, sensed, outdated x sensing off/on
  ndrql reproduce scale --grids 50,100         # also on the 100x100 grid -> results/scale-g100/
  ndrql reproduce table3 --prior-from oracle   # NDR-QL with the oracle's priors (a diagnostic) -> results/table3-oracle/
  ndrql reproduce dynamic
  ndrql reproduce scale --preset tuned         # only the tuned constants (default for table2/3, scale: spec,tuned)

Results go to results/<target>/ (markdown table, summary.json, PNG figures, one JSON per finished
task under tasks/). Re-running resumes: finished tasks are read back, not recomputed; a change of
seeds, configuration or model weights recomputes the affected tasks. NDR predictions are cached per
sample under results/predictions/. Runs with the same seeds give the same table whatever the
executor and number of workers.
"""

#: Config fields that become flags (``max_episodes`` -> ``--max-episodes``).
_QL_FLAGS = ("alpha", "epsilon", "gamma", "max_steps", "max_episodes", "window")
_PRIOR_FLAGS = ("r_max", "g_row", "g_col", "omega_crf", "omega_qi")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(
        subparsers, "reproduce",
        help="regenerate the paper's tables and figures (table1-4, dynamic, scale)",
        description="Run one of the paper's experiments end to end and write a markdown table and "
        "figures under the results directory. Sweeps are resumable and run on a local process pool "
        "(default) or on Ray.",
        examples=EXAMPLES)
    p.add_argument("target", choices=TARGETS, metavar="TARGET", help=f"one of: {', '.join(TARGETS)}")
    p.add_argument("--out", metavar="DIR", help="results directory (default: results/<target>)")
    p.add_argument("--data", metavar="DIR", help="dataset root (default: $NDRQL_DATASET, else a path-planning-dataset folder in the working directory)")
    add_weights_argument(p, PAPER_WEIGHTS)
    add_seed_options(p, seeds=10, seeds_help="runs per map and method (default: 10)", workers=2)
    p.add_argument("--executor", choices=("process", "serial", "ray"), default="process",
                   help="where tasks run (default: process; ray needs pip install 'ndrql[ray]')")
    p.add_argument("--ray-address", metavar="ADDR", help="connect to this Ray cluster instead of starting a local one")
    p.add_argument("--per-category", type=int, default=50, metavar="N",
                   help="scale: samples per category and split (default: 50 -> 200 SEEN + 200 UNSEEN)")
    p.add_argument("--epochs", type=int, default=2, metavar="N",
                   help="table4: training budget per variant, a complete N-epoch cosine schedule (default: 2)")
    p.add_argument("--run", action="store_true", help="table4: train the variants now, --workers at a time (default: evaluate "
                   "the trained ones and print the command)")
    p.add_argument("--runs", metavar="DIR", help="table4/sizing: root of the training run directories (default: "
                   "$NDRQL_CACHE/runs; table4 uses DIR/table4/<variant>)")
    p.add_argument("--rgp-weights", metavar="FILE", help="table1: RGP peer weights (default: $NDRQL_RGP_WEIGHTS or "
                   "the best checkpoint of $NDRQL_CACHE/runs/rgp)")
    p.add_argument("--grids", metavar="LIST", help="transfer, partial: planning grid sizes, safe grid (default: 50,100); scale: "
                   "the paper's grid, sizes other than 50 into results/scale-g<N> (default: 50)")
    p.add_argument("--prior-from", choices=PRIOR_SOURCES, default="model",
                   help="table3/scale: priors of the NDR-QL row, from the model (--weights; the table adds a row with "
                   "the oracle's priors and the model's share of its reduction) or the oracle (an 8-connected shortest "
                   "path of the grid with shortcuts, drawn as the labels are: a diagnostic, default --out results/<target>-oracle) (default: model)")
    p.add_argument("--per-family", type=int, default=None, metavar="N",
                   help="transfer: at most N maps per family of the evaluation set (default: all)")
    p.add_argument("--eval-set", default=None, metavar="NAME",
                   help="transfer: a development set of transfer_sets.json (default: transfer, the development report; sealed "
                   "sets are refused: only the release target reads them); release: sealed sets, comma-separated "
                   "(default: sealed; a large sealed set is evaluated at its own grid unless --grids is given); partial: "
                   "partial-dev (default) or the sealed sealed-partial (counted in the ledger, as release)")
    p.add_argument("--beliefs", metavar="LIST", default=None,
                   help="partial: the beliefs, comma-separated: blobs:FRACTION (share of the free space hidden), sensed "
                   "(what a robot sensed along routes), outdated (doors closed and opened) (default: "
                   "blobs:0.1,blobs:0.3,blobs:0.5,sensed,outdated)")
    p.add_argument("--sense", metavar="LIST", default="off,on",
                   help="partial: sensing off, on (plan --sense R, R = 8%% of the grid's side) or both (default: off,on)")
    p.add_argument("--rows", metavar="LIST", default=None,
                   help="transfer/release: the report's rows, comma-separated (IQL and NDR-QL (model) required), or all "
                   "(default: every row up to 100 cells; above, every row but QL and QL (tuned): ~10^7 steps per run)")
    p.add_argument("--learned-distance", action=argparse.BooleanOptionalAction, default=True,
                   help="transfer: Eq. 6 on the model's learned distance when the weights have a distance head; "
                   "--no-learned-distance: the straight line, the paper's Eq. 6 (default: on)")
    p.add_argument("--ledger", metavar="FILE", default="docs/release/ledger.json",
                   help="release, partial: the ledger that counts every evaluation of a sealed set, updated before the sets "
                   "are read (default: the ledger of the checkout it runs in, under its docs folder: release/ledger.json)")
    p.add_argument("--allow-dirty", action="store_true",
                   help="release, partial: run with uncommitted changes (the ledger records the commit as -dirty)")
    add_symmetries_argument(p, "a grid-mode model's prediction (--weights general) is averaged over N orientations of "
                            "the grid, as ndrql plan does (1, 2, 4, 8; the paper's model is never averaged)", DEFAULT_COUNT)
    p.add_argument("--limit", type=int, default=None, metavar="N", help="table1/table4/sizing: evaluate on the first N samples per split; "
                   "partial: the first N maps of a development set; "
                   "labels: N TEST/SEEN samples spread over the split (default: all 1,200)")
    p.add_argument("--preset", metavar="LIST", help="constants per method: spec, tuned or a preset FILE, or several "
                   "separated by commas, each run into its own folder and compared side by side (default: spec,tuned "
                   "for table2, table3 and scale; spec for dynamic and transfer; general for release, with --weights "
                   "general; for partial, plan's preset on a belief map: belief); flags below override a preset's values")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    add_config_flags(p.add_argument_group("Q-learning (docs/method.md)"), QLConfig, _QL_FLAGS)
    add_config_flags(p.add_argument_group("priors (docs/method.md)"), PriorConfig, _PRIOR_FLAGS)
    p.set_defaults(func=run)


def _options(args: argparse.Namespace):
    from ndrql.experiments.planning_runs import SweepOptions  # lazy: loads numba and tqdm

    cfgs = configs_from_flags(args, ((QLConfig, _QL_FLAGS), (PriorConfig, _PRIOR_FLAGS)))
    check_seeds(args.seed, args.seeds)
    check_int(args.workers, "--workers", 1, MAX_WORKERS)
    check_int(args.epochs, "--epochs", 1, 10_000)
    if args.limit is not None:
        check_int(args.limit, "--limit", 1)
    command = "ndrql " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if sys.argv and "ndrql" in sys.argv[0] else ""
    return SweepOptions(seeds=args.seeds, seed0=args.seed, workers=args.workers, executor=args.executor,
                        ray_address=args.ray_address, progress=not args.no_progress, ql=cfgs[0], priors=cfgs[1],
                        data=args.data, weights=args.weights, command=command, prior_from=args.prior_from,
                        symmetries=args.symmetries)


def _check_prior_from(args: argparse.Namespace) -> None:
    """``--prior-from oracle`` is for table3 and scale, and replaces the model (so no ``--weights``)."""
    if args.prior_from != "oracle":
        return
    if args.target not in ("table3", "scale"):
        raise NdrqlError(f"--prior-from oracle applies to table3 and scale, not {args.target}")
    if args.weights:
        raise NdrqlError("give either --weights or --prior-from oracle, not both")


def _scale_runs(args: argparse.Namespace, out: Path) -> list[tuple[int, Path]]:
    """``scale``'s planning grids (``--grids``, default the paper's 50) and their results folders."""
    from ndrql.dataset.mixture import parse_sizes  # lazy: loads torch and scipy
    from ndrql.maps.grid import PLANNING_SIZE

    grids = parse_sizes(args.grids) if args.grids else (PLANNING_SIZE,)
    return [(n, out if n == PLANNING_SIZE else out.with_name(f"{out.name}-g{n}")) for n in dict.fromkeys(grids)]


def _presets(args: argparse.Namespace, target: str) -> list:
    """The presets to run ``target`` with (``--preset``, else the default), with explicit flags on top."""
    names = args.preset
    if names is None:
        names = "spec,tuned" if target in ("table2", "table3", "scale") and builtin_path("tuned").is_file() else "spec"
        names = "general" if target in ("release", "partial") else names
    ql = {n: getattr(args, f"cfg_{n}") for n in _QL_FLAGS if getattr(args, f"cfg_{n}") is not None}
    pri = {n: getattr(args, f"cfg_{n}") for n in _PRIOR_FLAGS if getattr(args, f"cfg_{n}") is not None}
    out = [load_preset(n.strip()).with_overrides(ql, pri) for n in names.split(",") if n.strip()]
    if not out:
        raise NdrqlError("--preset is empty; give spec, tuned or a preset file")
    return out


def _release(args: argparse.Namespace, opts, out: Path, log) -> str:
    """``reproduce release``: every sealed set (or ``--eval-set``'s), one preset, counted in the ledger."""
    from ndrql.dataset.mixture import parse_sizes  # lazy: loads torch and scipy
    from ndrql.experiments.release import check_sealed_names, default_release, release  # lazy: loads scipy and tqdm
    from ndrql.experiments.transfer_report import parse_rows  # lazy: loads scipy

    names, grids = default_release(check_sealed_names([n.strip() for n in args.eval_set.split(",") if n.strip()])
                                   if args.eval_set else None, parse_sizes(args.grids) if args.grids else None)
    if args.per_family is not None:
        raise NdrqlError("--per-family does not apply to release: a sealed set is evaluated whole")
    presets = _presets(args, "release")
    if len(presets) != 1:
        raise NdrqlError("release takes one --preset")
    paths = release(out, names, rows=parse_rows(args.rows), ledger=args.ledger, allow_dirty=args.allow_dirty, weights=args.weights or "general",
                    preset=presets[0], grids=list(grids), seeds=args.seeds, seed0=args.seed,
                    workers=args.workers, executor=args.executor, progress=not args.no_progress,
                    command=opts.command, log=log)
    return ", ".join(str(x) for x in paths)


def _partial(args: argparse.Namespace, opts, out: Path, log) -> str:
    """``reproduce partial``: belief maps (:mod:`ndrql.experiments.partial_run`), one preset by name."""
    from ndrql.dataset.mixture import parse_sizes  # lazy: loads torch and scipy
    from ndrql.experiments.partial import DEFAULT_BELIEFS, parse_beliefs, parse_sense
    from ndrql.api import run_request  # lazy: loads the pipeline
    from ndrql.experiments.partial_run import partial  # lazy: loads scipy

    for flag, given in (("--per-family", args.per_family is not None), ("--rows", args.rows is not None)):
        if given:
            raise NdrqlError(f"{flag} does not apply to partial (its rows are fixed; --limit N takes the first N maps)")
    changed = [n for n in (*_QL_FLAGS, *_PRIOR_FLAGS) if getattr(args, f"cfg_{n}") is not None]
    if changed:
        raise NdrqlError(f"partial runs a preset's constants as plan does; --{changed[0].replace('_', '-')} does not "
                         f"apply (give --preset FILE)")
    preset = args.preset or plan_default_preset(args.weights, partial=True)  # plan's on a belief map
    if "," in preset:
        raise NdrqlError("partial takes one --preset")
    load_preset(preset)
    beliefs = args.beliefs or DEFAULT_BELIEFS
    parse_beliefs(beliefs)
    path = partial(out, runner=run_request, set_name=args.eval_set or "partial-dev", grids=tuple(parse_sizes(args.grids or "50,100")),
                   beliefs=beliefs, senses=parse_sense(args.sense), seeds=args.seeds, seed0=args.seed,
                   weights=args.weights, preset=preset, workers=args.workers, executor=args.executor, limit=args.limit,
                   ledger=args.ledger, allow_dirty=args.allow_dirty, command=opts.command, progress=not args.no_progress,
                   log=log)
    return str(path)


#: Targets that need torch (the model's predictions run on torch for the tables, training, the dataset's mixture):
#: said before anything else, not as a missing dataset later. ``--prior-from oracle`` needs no model.
TORCH_TARGETS = ("table1", "table2", "table3", "table4", "scale", "dynamic", "sizing", "transfer", "release", "all")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    if args.target in TORCH_TARGETS and args.prior_from != "oracle":
        require_torch(f"reproduce {args.target}")
    if args.executor == "ray":
        if not ray_available():
            raise NdrqlError("--executor ray needs Ray: pip install 'ndrql[ray]' (or pip install ray)")
    if args.per_category < 1 or args.per_category > 300:
        raise NdrqlError(f"--per-category must be in 1..300, got {args.per_category}")
    _check_prior_from(args)
    opts = _options(args)
    targets = ["table1", "table3", "table2", "dynamic", "scale", "table4", "sizing", "labels"] if args.target == "all" else [args.target]
    log = lambda msg: print(msg, file=sys.stderr)  # noqa: E731
    suffix = "-oracle" if args.prior_from == "oracle" else ""
    for target in targets:
        out = Path(args.out) / target if (args.out and args.target == "all") else Path(args.out or Path("results") / f"{target}{suffix}")
        if target in ("table3", "table2", "scale", "dynamic"):
            from ndrql.experiments.dynamic import dynamic  # lazy: loads numba and tqdm
            from ndrql.experiments.scale import scale  # lazy: loads numba and tqdm
            from ndrql.experiments.table2 import table2  # lazy: loads numba and tqdm
            from ndrql.experiments.table3 import table3  # lazy: loads numba and tqdm

            fns = {"table3": lambda o, d: table3(o, d, log=log), "table2": lambda o, d: table2(o, d, log=log),
                   "dynamic": lambda o, d: dynamic(o, d, log=log)}
            runs = [(fns[target], out)] if target != "scale" else [
                (lambda o, d, n=n: scale(o, d, per_category=args.per_category, log=log, grid=n), d)
                for n, d in _scale_runs(args, out)]
            paths = [x for fn, d in runs for x in run_presets(target, fn, opts, d, _presets(args, target), log=log)]
            path = ", ".join(str(x) for x in paths)
        elif target == "table1":
            from ndrql.experiments.table1 import table1  # lazy: loads torch

            path = table1(out, data=args.data, weights=args.weights, rgp_weights=args.rgp_weights, limit=args.limit,
                          progress=not args.no_progress, command=opts.command, log=log)
        elif target == "labels":
            path = labels_check(out, data=args.data, limit=args.limit, seed=args.seed, command=opts.command,
                                progress=not args.no_progress, log=log)
        elif target == "transfer":
            from ndrql.dataset.mixture import parse_sizes  # lazy: loads torch and scipy
            from ndrql.experiments.transfer import transfer  # lazy: loads scipy and tqdm
            from ndrql.experiments.transfer_report import parse_rows  # lazy: loads scipy

            from ndrql.experiments.eval_sets import eval_spec  # lazy: loads scipy

            set_name = args.eval_set or "transfer"
            eval_spec(set_name)  # an unknown or sealed set is one line now, before the model loads
            if args.per_family is not None:
                check_int(args.per_family, "--per-family", 1)
            grids = parse_sizes(args.grids or "50,100")
            rows = parse_rows(args.rows)
            paths = run_presets(target, lambda o, d: transfer(
                d, weights=args.weights, set_name=set_name, grids=grids, seeds=args.seeds, seed0=args.seed,
                per_family=args.per_family, workers=args.workers, executor=args.executor, progress=not args.no_progress,
                command=opts.command, log=log, preset=o.preset, symmetries=args.symmetries,
                learned_distance=args.learned_distance, rows=rows), opts, out, _presets(args, target), log=log)
            path = ", ".join(str(x) for x in paths)
        elif target == "release":
            path = _release(args, opts, out, log)
        elif target == "partial":
            path = _partial(args, opts, out, log)
        elif target == "sizing":
            from ndrql.experiments.sizing import sizing  # lazy: loads torch

            path = sizing(out, runs=args.runs, command=opts.command, data=args.data, limit=args.limit,
                          progress=not args.no_progress, log=log)
        else:
            from ndrql.experiments.table4 import table4  # lazy: loads torch and tqdm

            path = table4(out, data=args.data, epochs=args.epochs, run=args.run, runs=args.runs, workers=args.workers,
                          limit=args.limit, progress=not args.no_progress, command=opts.command, log=log)
        print(f"{target}: wrote {path}")
    return 0
