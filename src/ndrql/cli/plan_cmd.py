"""``ndrql plan``: Q-learning on the 50x50 planning grid with the paper's priors, many seeds."""

from __future__ import annotations

import argparse
import dataclasses
from typing import Any

EXAMPLES = """examples:
  ndrql plan --sample ../shared/data/path-planning-dataset:seen:0 --method IQL --seeds 10 --json out.json
  ndrql plan map.png --start 25,179 --goal 167,5 --method QL --png out/ql.png
  ndrql plan --sample ../shared/data/path-planning-dataset:seen:0 --compare QL,D-Q,IQL,O-QL --seeds 10
  ndrql plan --sample DATA:seen:0 --method NDR-QL --prior-from preds.npz   # region, guideline arrays

methods: QL, D-C, N-C, D-Q, N-Q, IQL, O-QL, NDR-QL (N-C, N-Q, NDR-QL need the NDR predictions).
Seeds S, S+1, ..., S+N-1 (--seed S --seeds N); the same seed gives the same run on any machine
load and any number of workers.
"""

#: Config fields that become flags (``alpha`` -> ``--alpha``), from the frozen dataclasses.
_QL_FLAGS = ("alpha", "epsilon", "gamma", "max_steps", "max_episodes", "window",
             "reward_collision", "reward_goal", "reward_revisit")
_PRIOR_FLAGS = ("r0", "r_max", "g_row", "g_col", "omega_crf", "omega_qi", "mask_low", "thd_start", "thd_step")


def _add_config_flags(group: argparse._ArgumentGroup, cls: type, names: tuple[str, ...]) -> None:
    from ndrql.planning.config import field_docs

    docs = field_docs(cls)
    defaults = cls()
    types = {f.name: f.type for f in dataclasses.fields(cls)}
    for name in names:
        default = getattr(defaults, name)
        kind = int if "int" in str(types[name]) else float
        shown = "4 x cells" if default is None else default
        group.add_argument(f"--{name.replace('_', '-')}", dest=f"cfg_{name}", type=kind, default=None,
                           metavar="V", help=f"{docs[name]} (default: {shown})")


def register(subparsers: argparse._SubParsersAction) -> None:
    from ndrql.cli.common import add_problem_arguments
    from ndrql.planning.config import PriorConfig, QLConfig

    p = subparsers.add_parser(
        "plan",
        help="Q-learning path planning with the paper's priors (QL, IQL, O-QL, NDR-QL, ...)",
        description="Tabular Q-learning on the planning grid (SPEC sections 2-4): runs one method, or "
        "several with --compare, on the same seeds, reports convergence steps, the converged greedy "
        "path and its ratio to the A* optimum. Start and goal map to planning cells as for `astar`.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_problem_arguments(p)
    p.add_argument("--method", default="QL", metavar="NAME", help="planning method (default: QL)")
    p.add_argument("--compare", metavar="A,B,...", help="run these methods on the same seeds and print a table")
    p.add_argument("--seeds", type=int, default=1, metavar="N", help="number of runs (seeds S..S+N-1; default: 1)")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="first seed (default: 0)")
    p.add_argument("--workers", type=int, default=None, metavar="N", help="parallel workers (default: all cores)")
    p.add_argument("--prior-from", metavar="FILE.npz",
                   help="NDR predictions: arrays 'region' and 'guideline' at the map's resolution, values in [0, 1]")
    p.add_argument("--size", type=int, default=50, metavar="N", help="planning grid side (default: 50, paper)")
    p.add_argument("--json", metavar="FILE", help="write grid, start, goal and every run as JSON ('-' for stdout)")
    p.add_argument("--records", action="store_true", help="include per-episode records in the JSON")
    p.add_argument("--png", metavar="FILE", help="write a picture of the map and the first run's path per method")
    _add_config_flags(p.add_argument_group("Q-learning (SPEC 2-3)"), QLConfig, _QL_FLAGS)
    _add_config_flags(p.add_argument_group("priors (SPEC 4)"), PriorConfig, _PRIOR_FLAGS)
    p.set_defaults(func=run)


def _configs(args: argparse.Namespace):
    from ndrql.errors import NdrqlError
    from ndrql.planning.config import PriorConfig, QLConfig

    out = []
    for cls, names in ((QLConfig, _QL_FLAGS), (PriorConfig, _PRIOR_FLAGS)):
        kwargs = {n: getattr(args, f"cfg_{n}") for n in names if getattr(args, f"cfg_{n}") is not None}
        try:
            out.append(cls(**kwargs))
        except ValueError as exc:
            raise NdrqlError(f"bad option: {exc}") from None
    return out[0], out[1]


def _load_ndr(args: argparse.Namespace, grid_map: Any, problem: Any, shape: tuple[int, int]):
    from ndrql.errors import NdrqlError
    from ndrql.planning.methods import downscale_priors, load_prior_file, predict_priors

    if args.prior_from:
        region, guideline = load_prior_file(args.prior_from)
    else:
        region, guideline = predict_priors(grid_map.obstacles, problem.start, problem.goal)
    for name, arr in (("region", region), ("guideline", guideline)):
        if arr.shape != grid_map.shape:
            raise NdrqlError(f"{name} in {args.prior_from} is {arr.shape[0]}x{arr.shape[1]} but the map is "
                             f"{grid_map.height}x{grid_map.width}; predictions must be at the map's resolution")
    return downscale_priors(region, guideline, shape)


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


def run(args: argparse.Namespace) -> int:
    from ndrql.cli.common import map_info, resolve_problem, save_figure, warnings_to_stderr, write_json
    from ndrql.errors import NdrqlError
    from ndrql.maps.grid import PlanningGrid
    from ndrql.planning.methods import build_priors, get_method
    from ndrql.planning.results import summarize
    from ndrql.planning.runner import PlanJob, run_many

    if args.seeds < 1:
        raise NdrqlError(f"--seeds must be >= 1, got {args.seeds}")
    if args.size < 1:
        raise NdrqlError(f"--size must be positive, got {args.size}")
    if args.workers is not None and args.workers < 1:
        raise NdrqlError(f"--workers must be >= 1, got {args.workers}")
    names = [n for n in (args.compare.split(",") if args.compare else [args.method]) if n.strip()]
    methods = [get_method(n.strip()) for n in names]
    if not methods:
        raise NdrqlError("--compare needs at least one method name")
    ql_cfg, prior_cfg = _configs(args)
    problem = resolve_problem(args)
    grid_map = problem.grid_map
    with warnings_to_stderr():
        pg = PlanningGrid.from_map(grid_map, problem.start, problem.goal, size=args.size)
    region = guideline = None
    if any(m.needs_ndr for m in methods):
        region, guideline = _load_ndr(args, grid_map, problem, pg.shape)
    print(f"map: {grid_map.source} ({grid_map.height}x{grid_map.width}); planning grid {pg.shape[0]}x{pg.shape[1]}, "
          f"start {pg.start}, goal {pg.goal}")
    thresholds: dict[str, float | None] = {}
    with warnings_to_stderr():  # NDR-QI's "no threshold connects" warning, once per method
        for m in methods:
            if m.n_qi:
                thresholds[m.name] = build_priors(m, pg.blocked, pg.start, pg.goal, region, guideline, prior_cfg).threshold
    seeds = list(range(args.seed, args.seed + args.seeds))
    jobs = [PlanJob(pg.blocked, pg.start, pg.goal, m.name, s, ql_cfg, prior_cfg, region, guideline, args.records)
            for m in methods for s in seeds]
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # already reported above
        results = run_many(jobs, workers=args.workers)
    opt = results[0].astar_length
    print(f"A* optimum: {opt} moves; seeds {seeds[0]}..{seeds[-1]}; max {ql_cfg.max_episodes} episodes")
    for name, thd in thresholds.items():
        print(f"{name}: NDR-QI threshold {thd if thd is not None else 'none (mask 0 everywhere)'}")
    if len(methods) == 1 and len(seeds) <= 3:
        for r in results:
            if r.converged:
                print(f"{r.method} seed {r.seed}: converged after {r.convergence_episode:,} episodes, "
                      f"{r.convergence_steps:,} steps; path {r.path_length} moves ({r.length_ratio:.3f} x A*); "
                      f"{r.wall_time:.2f} s")
            else:
                print(f"{r.method} seed {r.seed}: NOT converged in {r.episodes:,} episodes ({r.total_steps:,} steps)")
    else:
        print("\n".join(_table([m.name for m in methods], results)))
    not_conv = sum(not r.converged for r in results)
    if not_conv:
        print(f"{not_conv} of {len(results)} runs did not converge (reported, not dropped)")
    if args.json:
        out: dict[str, Any] = {
            "map": map_info(grid_map),
            **{k: v for k, v in problem.info.items() if k != "source"},
            "planning_size": list(pg.shape),
            "grid": pg.to_strings(),
            "start": list(pg.start),
            "goal": list(pg.goal),
            "source_start": list(pg.source_start),
            "source_goal": list(pg.source_goal),
            "snapped": {"start": pg.snapped[0], "goal": pg.snapped[1]},
            "astar_length": opt,
            "methods": [m.name for m in methods],
            "seeds": seeds,
            "config": dataclasses.asdict(ql_cfg),
            "prior_config": dataclasses.asdict(prior_cfg),
            "prior_from": args.prior_from,
            "summary": {
                m.name: {
                    "runs": sum(r.method == m.name for r in results),
                    "not_converged": sum(r.method == m.name and not r.converged for r in results),
                    "convergence_steps": summarize([r.convergence_steps for r in results if r.method == m.name and r.converged]),
                    "length_ratio": summarize([r.length_ratio for r in results if r.method == m.name and r.converged]),
                }
                for m in methods
            },
            "runs": [r.to_dict(include_records=args.records) for r in results],
        }
        print(f"wrote {write_json(args.json, out)}")
    if args.png:
        first = {m.name: next(r for r in results if r.method == m.name) for m in methods}

        def draw(ax: Any) -> None:
            from ndrql.maps.astar import astar4
            from ndrql.maps.grid import cell_to_point
            from ndrql.viz.maps import plot_endpoints, plot_occupancy, plot_path

            shape = grid_map.shape
            plot_occupancy(ax, grid_map.obstacles, zorder=1)
            plot_occupancy(ax, pg.blocked, color="tab:orange", alpha=0.3,
                           extent=(-0.5, shape[1] - 0.5, shape[0] - 0.5, -0.5), zorder=2)
            best = astar4(pg.blocked, pg.start, pg.goal).path
            plot_path(ax, [cell_to_point(c, shape, pg.shape) for c in best], color="0.5", linewidth=1.0,
                      label=f"A* ({len(best) - 1})")
            colours = ["tab:red", "tab:green", "tab:purple", "tab:cyan", "tab:brown", "tab:pink", "tab:olive", "tab:blue"]
            for i, (name, r) in enumerate(first.items()):
                if r.path:
                    tag = "" if r.converged else ", not converged"
                    plot_path(ax, [cell_to_point(c, shape, pg.shape) for c in r.path], color=colours[i % len(colours)],
                              label=f"{name} seed {r.seed} ({r.path_length}{tag})")
            plot_endpoints(ax, pg.source_start, pg.source_goal)
            ax.set_xlim(-0.5, shape[1] - 0.5)
            ax.set_ylim(shape[0] - 0.5, -0.5)
            ax.set_aspect("equal")
            ax.legend(loc="upper right", fontsize=7, framealpha=0.8)

        print(f"wrote {save_figure(draw, args.png)}")
    return 0
