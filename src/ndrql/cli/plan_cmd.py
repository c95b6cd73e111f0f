"""``ndrql plan``: plan a path on a map with the pretrained NDR model and Q-learning (a thin wrapper of :func:`ndrql.api.solve`)."""

from __future__ import annotations

import argparse
from typing import Any

EXAMPLES = """examples:
  ndrql plan map.png --start 25,179 --goal 167,5 --png out/plan.png --json out/plan.json
  ndrql plan --sample ../shared/data/path-planning-dataset:seen:0            # start and goal from the sample
  ndrql plan office.yaml --start 120,80 --goal 30,200                        # ROS map_server map
  ndrql plan arena.map --scen arena.map.scen --index 3                       # MovingAI map + scenario 3
  ndrql plan map.png --start 25,179 --goal 167,5 --compare QL,IQL,NDR-QL --seeds 10 --png out/cmp.png
  ndrql plan map.png --start 25,179 --goal 167,5 --method N-Q --prior-from preds.npz

methods (default NDR-QL): QL, D-C, N-C, D-Q, N-Q, IQL, O-QL, NDR-QL; N-C, N-Q and NDR-QL use the
NDR model (shipped weights, or --weights FILE, or $NDRQL_WEIGHTS; --prior-from FILE.npz gives the
predictions instead). Points are ROW,COL map pixels. Seeds S..S+N-1 (--seed S --seeds N); the same
seed gives the same run on any machine load and any number of workers. Time per stage: load (model
weights), predict, priors, learn; start-up (torch import, loading the compiled kernel) is per process.
"""

#: Config fields that become flags (``alpha`` -> ``--alpha``), from the frozen dataclasses.
_QL_FLAGS = ("alpha", "epsilon", "gamma", "max_steps", "max_episodes", "window",
             "reward_collision", "reward_goal", "reward_revisit")
_PRIOR_FLAGS = ("r0", "r_max", "g_row", "g_col", "omega_crf", "omega_qi", "mask_low", "thd_start", "thd_step")


def register(subparsers: argparse._SubParsersAction) -> None:
    from ndrql.cli.options import add_config_flags
    from ndrql.api import PlanSettings
    from ndrql.cli.common import add_problem_arguments
    from ndrql.planning.config import PriorConfig, QLConfig, field_docs

    p = subparsers.add_parser(
        "plan",
        help="plan a path on your map with NDR-QL (or QL, IQL, O-QL, ...): summary, JSON, figure",
        description="Plan a path on a map (image, ROS map_server YAML, MovingAI .map with --scen, .npy, or a "
        "dataset sample): the NDR model predicts region and guideline, the method's priors (paper Eqs. 2-7) "
        "guide tabular Q-learning on the planning grid (SPEC sections 1-4) until the greedy path is stable. "
        "Prints convergence episode and steps, the greedy path length against the A* optimum, the NDR-QI "
        "threshold and the time of each stage. Start and goal map to planning cells as for `astar`.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_problem_arguments(p)
    p.add_argument("--scen", metavar="FILE[:K]", help="MovingAI .scen file: start and goal from scenario K (or --index K; default 0)")
    p.add_argument("--index", type=int, default=None, metavar="K", help="scenario number in --scen (0-based)")
    p.add_argument("--method", default="NDR-QL", metavar="NAME", help="planning method (default: NDR-QL)")
    p.add_argument("--compare", metavar="A,B,...", help="run these methods on the same seeds and print a table")
    p.add_argument("--seeds", type=int, default=1, metavar="N", help="number of runs (seeds S..S+N-1; default: 1)")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="first seed (default: 0)")
    p.add_argument("--workers", type=int, default=None, metavar="N", help="parallel workers (default: all cores)")
    p.add_argument("--weights", metavar="FILE", help="NDR model weights (default: $NDRQL_WEIGHTS or the shipped ndr_default.pt)")
    p.add_argument("--prior-from", metavar="FILE.npz",
                   help="NDR predictions instead of the model: arrays 'region' and 'guideline' at the map's resolution, in [0, 1]")
    from ndrql.model.predict import BACKENDS

    settings = PlanSettings()
    docs = field_docs(PlanSettings)
    p.add_argument("--size", type=int, default=settings.size, metavar="N", help=f"{docs['size']} (default: {settings.size})")
    p.add_argument("--max-pixels", type=int, default=settings.max_map_pixels, metavar="N",
                   help=f"{docs['max_map_pixels']} (default: {settings.max_map_pixels:,})")
    p.add_argument("--threads", type=int, default=settings.threads, metavar="N",
                   help=f"{docs['threads']} (default: {settings.threads})")
    p.add_argument("--backend", choices=BACKENDS, default=settings.backend,
                   help=f"{docs['backend']} (default: {settings.backend})")
    p.add_argument("--json", metavar="FILE", help="write grid, start, goal, timings and every run as JSON ('-': stdout, the summary then goes to stderr)")
    p.add_argument("--records", action="store_true", help="include per-episode records in the JSON")
    p.add_argument("--png", metavar="FILE", help="write a figure: map, NDR region and guideline, learned and A* paths "
                   "(one panel per method with --compare)")
    add_config_flags(p.add_argument_group("Q-learning (SPEC 2-3)"), QLConfig, _QL_FLAGS)
    add_config_flags(p.add_argument_group("priors (SPEC 4)"), PriorConfig, _PRIOR_FLAGS)
    p.set_defaults(func=run)


def _configs(args: argparse.Namespace):
    from ndrql.cli.options import configs_from_flags
    from ndrql.planning.config import PriorConfig, QLConfig

    ql_cfg, prior_cfg = configs_from_flags(args, ((QLConfig, _QL_FLAGS), (PriorConfig, _PRIOR_FLAGS)))
    return ql_cfg, prior_cfg


def _fmt(v: Any, nd: int = 0) -> str:
    if v is None:
        return "-"
    return f"{v:,.{nd}f}"


def _table(methods: list[str], results: list[Any]) -> list[str]:
    from ndrql.planning.results import summarize

    head = (f"{'method':<8} {'conv':>6} {'steps mean':>11} {'median':>9} {'95% CI':>21} {'episodes':>9} "
            f"{'path/A*':>8} {'short/long':>12}")
    lines = [head, "-" * len(head)]
    for m in methods:
        rs = [r for r in results if r.method == m]
        conv = [r for r in rs if r.converged]
        st = summarize([r.convergence_steps for r in conv])
        ep = summarize([r.convergence_episode for r in conv])
        ratio = summarize([r.length_ratio for r in conv])
        short = summarize([r.shortest_success_length for r in conv])
        long_ = summarize([r.longest_success_length for r in conv])
        ci = f"[{_fmt(st['ci95_low'])}, {_fmt(st['ci95_high'])}]" if st["ci95_low"] is not None else "-"
        lines.append(
            f"{m:<8} {len(conv):>3}/{len(rs):<2} {_fmt(st['mean']):>11} {_fmt(st['median']):>9} {ci:>21} "
            f"{_fmt(ep['mean']):>9} {_fmt(ratio['mean'], 3):>8} {_fmt(short['mean']) + '/' + _fmt(long_['mean']):>12}"
        )
    return lines


def _scenario(args: argparse.Namespace) -> tuple[str | None, int]:
    if not args.scen:
        if args.index is not None:
            from ndrql.errors import NdrqlError

            raise NdrqlError("--index needs --scen FILE")
        return None, 0
    path, idx = args.scen, 0
    head, sep, tail = args.scen.rpartition(":")
    if sep and tail.isdigit():
        path, idx = head, int(tail)
    return path, idx if args.index is None else args.index


def _summary(report: Any) -> list[str]:
    """The short summary printed by ``plan``: runs, A* optimum, NDR-QI threshold, time per stage."""
    from ndrql.api import WORK_STAGES

    lines = []
    opt = report.astar_length
    single = len(report.methods) == 1 and len(report.seeds) <= 3
    if single:
        for r in report.results:
            if r.converged:
                lines.append(f"{r.method} seed {r.seed}: converged after {r.convergence_episode:,} episodes, "
                             f"{r.convergence_steps:,} steps; path {r.path_length} moves ({r.length_ratio:.3f} x A*)")
            else:
                tail = f"; last greedy path {r.path_length} moves" if r.path_length is not None else ""
                lines.append(f"{r.method} seed {r.seed}: NOT converged in {r.episodes:,} episodes "
                             f"({r.total_steps:,} steps){tail}")
    lines.append(f"A* optimum: {opt} moves; seeds {report.seeds[0]}..{report.seeds[-1]}; "
                 f"max {report.config.max_episodes} episodes")
    if not single:
        lines += _table(list(report.methods), list(report.results))
    for name, thd in report.thresholds.items():
        lines.append(f"{name}: NDR-QI threshold {f'{thd:.2f}' if thd is not None else 'none (mask 0 everywhere)'}")
    not_conv = sum(not r.converged for r in report.results)
    if not_conv:
        lines.append(f"{not_conv} of {len(report.results)} runs did not converge (reported, not dropped)")
    t = report.timings
    stages = ", ".join(f"{s} {t[s]:.3f}" for s in WORK_STAGES)
    lines.append(f"time (s): {stages}; work {report.work_time:.3f} "
                 f"(+ map {t['map']:.3f}, start-up {t['startup']:.2f})")
    return lines


def _short(path: str) -> str:
    """``path`` relative to the working directory when it lies below it, else as given."""
    import os

    try:
        rel = os.path.relpath(path)
    except ValueError:  # another drive (Windows)
        return path
    return rel if not rel.startswith("..") else path


def _save(fig: Any, path: str) -> Any:
    from ndrql.io import save_figure

    return save_figure(fig, path)


def run(args: argparse.Namespace) -> int:
    import functools
    import sys

    from ndrql.api import PlanSettings, solve
    from ndrql.cli.common import load_map_argument, parse_point, Problem, warnings_to_stderr, write_json
    from ndrql.errors import NdrqlError
    from ndrql.planning.methods import get_method, load_prior_file

    from ndrql.limits import MAX_WORKERS, check_int, check_seeds

    seeds = check_seeds(args.seed, args.seeds)  # a range: --seeds is bounded, every seed below 2**63
    from ndrql.cli.common import check_outputs

    check_outputs(args.json, args.png)  # before the work: an unwritable output is one line now, not after planning
    if args.workers is not None:
        check_int(args.workers, "--workers", 1, MAX_WORKERS)
    if args.weights and args.prior_from:
        raise NdrqlError("give either --weights or --prior-from, not both")
    names = [n.strip() for n in (args.compare.split(",") if args.compare else [args.method]) if n.strip()]
    if not names:
        raise NdrqlError("--compare needs at least one method name")
    methods = [get_method(n).name for n in names]
    ql_cfg, prior_cfg = _configs(args)
    if args.threads < 1:
        raise NdrqlError(f"--threads must be >= 1, got {args.threads}")
    settings = PlanSettings(size=args.size, max_map_pixels=args.max_pixels, threads=args.threads, backend=args.backend)
    scen, index = _scenario(args)
    loaded = load_map_argument(args)
    if isinstance(loaded, Problem):  # a dataset sample: its points unless overridden
        grid_map, info = loaded.grid_map, dict(loaded.info)
        start = parse_point(args.start, "--start") if args.start else loaded.start
        goal = parse_point(args.goal, "--goal") if args.goal else loaded.goal
    else:
        grid_map, info = loaded, {"source": loaded.source}
        start = parse_point(args.start, "--start") if args.start else None
        goal = parse_point(args.goal, "--goal") if args.goal else None
        if scen is None and (start is None or goal is None):
            missing = [f for f, v in (("--start", start), ("--goal", goal)) if v is None]
            raise NdrqlError(f"{' and '.join(missing)} required with a map file (ROW,COL in map pixels), or --scen FILE")
    predictions = None
    if args.prior_from and any(get_method(m).needs_ndr for m in methods):
        predictions = load_prior_file(args.prior_from)
        info["prior_from"] = args.prior_from
    with warnings_to_stderr():
        report = solve(grid_map, start, goal, methods, list(seeds),
                       weights=args.weights, predictions=predictions, config=ql_cfg, prior_config=prior_cfg,
                       settings=settings, scen=scen, scen_index=index, workers=args.workers,
                       keep_records=args.records, info=info)
    pg = report.grid
    # with --json - the JSON owns stdout; the summary goes to stderr
    echo = functools.partial(print, file=sys.stderr if args.json == "-" else sys.stdout)
    echo(f"map: {grid_map.source} ({grid_map.height}x{grid_map.width}); planning grid {pg.shape[0]}x{pg.shape[1]}, "
          f"start {pg.start}, goal {pg.goal}")
    if report.weights:
        echo(f"model: {_short(report.weights)} ({report.info.get('backend', 'torch')})")
    echo("\n".join(_summary(report)))
    if args.json:
        written = write_json(args.json, report.to_dict(include_records=args.records))
        if args.json != "-":
            echo(f"wrote {written}")
    if args.png:
        from ndrql.viz.plan import compare_figure, plan_figure

        fig = plan_figure(report) if len(methods) == 1 else compare_figure(report)
        echo(f"wrote {_save(fig, args.png)}")
    return 0
