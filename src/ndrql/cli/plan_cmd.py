"""``ndrql plan``: plan a path on a map with the pretrained NDR model and Q-learning (a thin wrapper of :func:`ndrql.api.solve`)."""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path
from typing import Any

from ndrql.api import PlanSettings, build_request, run_request
from ndrql.cli.common import (add_batch_group, add_dpi_argument, add_path_out_arguments, add_problem_arguments,
                              add_symmetries_argument, add_weights_argument, check_dpi, check_outputs, map_or_sample,
                              parse_point, parse_scen, warnings_to_stderr, write_json)
from ndrql.cli.options import add_command, add_seed_options, budget_seconds, grid_size
from ndrql.cli.plan_help import PLAIN_METHOD, PRIOR_FROM_HELP, add_constant_groups, plain_preset
from ndrql.cli.plan_batch import run_batch
from ndrql.cli.plan_report import summary_lines
from ndrql.dataset.views import view_note
from ndrql.errors import FallbackWarning, NdrqlError
from ndrql.io import save_figure, write_json as io_write_json, write_text
from ndrql.limits import MAX_WORKERS, check_finite, check_int, check_records, check_seeds
from ndrql.maps.problem import GridMapProblem
from ndrql.maps.world import has_world_frame, nav_path, parse_world_point
from ndrql.model.predict import BACKENDS
from ndrql.pipeline.predictions import load_predictions
from ndrql.pipeline.request import DEFAULT_FALLBACK, PRIOR_FIELDS, QL_FIELDS
from ndrql.pipeline.settings import DEFAULT_PREDICT_BUDGET, GRID_RULES
from ndrql.pipeline.sources import SOURCE_NAMES
from ndrql.planning.config import QLConfig, field_docs
from ndrql.planning.methods import get_method
from ndrql.viz.plan import compare_figure, plan_figure

DESCRIPTION = ("Plan a path on a map (image, ROS map_server YAML, MovingAI .map with --scen, .npy, or a dataset "
               "sample): the NDR model predicts region and guideline, the method's priors (paper Eqs. 2-7) guide "
               "tabular Q-learning on the planning grid (docs/method.md) until the greedy path is stable. Prints "
               "convergence episode and steps, the greedy path length against the A* optimum, the NDR-QI threshold "
               "and the time of each stage. Start and goal map to planning cells as for `astar`.")

EXAMPLES = """examples:
  ndrql plan --example                                                       # the bundled map, from any folder
  ndrql plan map.png --start 25,179 --goal 167,5 --png out/plan.png --json out/plan.json
  ndrql plan --sample path-planning-dataset:seen:0    # a dataset sample (git clone https://github.com/JimOriginal/path-planning-dataset)
  ndrql plan office.yaml --start 120,80 --goal 30,200                        # ROS map_server map
  ndrql plan arena.map --scen arena.map.scen --index 3                       # MovingAI map + scenario 3
  ndrql plan arena.map --scen arena.map.scen --all --jsonl arena.jsonl       # every scenario vs its optimal length
  ndrql plan map.png --start 25,179 --goal 167,5 --compare QL,IQL,NDR-QL --seeds 10 --png out/cmp.png
  ndrql plan map.png --start 25,179 --goal 167,5 --method N-Q --prior-from preds.npz
  ndrql plan map.png --start 25,179 --goal 167,5 --prior-from model           # the network's priors on a known map
  ndrql plan office.yaml --start-world 2.5,4.0 --goal-world 12.0,1.5,1.57 --robot-radius 0.2 --path-out plan.yaml
  ndrql plan floor.png --start 300,200 --goal 1700,1800 --grid area --size 50   # the paper's grid instead of the safe one

methods (default NDR-QL): QL, D-C, N-C, D-Q, N-Q, IQL, O-QL, NDR-QL (the paper's), IQL-BFS (IQL
with Eq. 5 on the exact BFS distance: a reference that needs no model) and IQL-NDR (IQL with Eq. 5 on the
prior source's goal distance: the model's on a belief map); N-C, N-Q, NDR-QL and IQL-NDR use the
NDR model (shipped paper, general or belief weights, or --weights FILE, or $NDRQL_WEIGHTS) where their prior source is the
model; on a map the planner fully knows their priors come from the exact BFS distance (--prior-from says which). Points are ROW,COL map pixels. Seeds S..S+N-1 (--seed S --seeds N); the same
seed gives the same run on any machine load and any number of workers. Time per stage: load (model
weights), predict, priors, learn; start-up (torch import, loading the compiled kernel) is per process.

planning grid: on a map file the safe grid (square cells, a cell blocked when any of its pixels is an
obstacle after inflating obstacles by --robot-radius, --size auto: the coarsest grid whose route is
within 8% of the map's own shortest route); with --sample the paper's 50x50 area grid (--grid area).
Every learned path is checked on the full map: a path that crosses an obstacle is reported
("path collides", JSON "collisions", red marks in the figure) and not called a success (exit
status 0). Q-learning's episodes are capped at 4 x cells moves, so grids above 256 cells per side
can take minutes.
"""

#: Config fields that become flags (``alpha`` -> ``--alpha``), from the frozen dataclasses.
_QL_FLAGS = QL_FIELDS
_PRIOR_FLAGS = PRIOR_FIELDS
#: ``--prior-from`` values that name a source rather than a file.
PRIOR_SOURCE_NAMES = SOURCE_NAMES[:-1]


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(subparsers, "plan",
                    help="plan a path on your map with NDR-QL (or QL, IQL, O-QL, ...): summary, JSON, figure",
                    description=DESCRIPTION, examples=EXAMPLES)
    settings = PlanSettings()
    docs = field_docs(PlanSettings)
    inp = p.add_argument_group("input: map, start and goal")
    add_problem_arguments(inp)
    inp.add_argument("--sense", type=float, default=None, metavar="R",
                    help="with --hide (or --unknown free): revealed as it moves, the cells within R planning cells "
                    "of the agent (line of sight) become known and the priors are rebuilt, the Q-table kept")
    inp.add_argument("--sense-every", type=int, default=None, metavar="E",
                    help="with --sense: episodes between rebuilds while the map keeps changing (default: 1)")
    inp.add_argument("--hide", metavar="MASK", help="a mask of the map's size (.npy, or an image: non-zero / "
                    "not black = unknown): the planner's priors see the map with these pixels unknown (counted "
                    "free) while the agent learns on the true map; the JSON's belief gives the true optimum; with no "
                    "--weights, the model is the shipped belief weights when installed (else IQL-BFS runs)")
    inp.add_argument("--scen", metavar="FILE[:K]", help="MovingAI .scen file: start and goal from scenario K (or --index K; default 0)")
    inp.add_argument("--max-pixels", type=int, default=settings.max_map_pixels, metavar="N",
                     help=f"{docs['max_map_pixels']} (default: {settings.max_map_pixels:,})")

    method = p.add_argument_group("method")
    method.add_argument("--method", default=PLAIN_METHOD, metavar="NAME", help=f"planning method (default: {PLAIN_METHOD})")
    method.add_argument("--compare", metavar="A,B,...", help="run these methods on the same seeds and print a table")
    add_seed_options(method, seeds=1, seeds_help="number of runs (seeds S..S+N-1; default: 1)", workers=None)
    add_weights_argument(method)
    method.add_argument("--preset", metavar="NAME", help="constants per method: spec (the paper's), tuned (searched with "
                        "ndrql tune for the paper weights on the paper's 50x50 grids), general (searched for the general "
                        "weights on generated maps, per grid size) or a preset FILE; the constant flags override its "
                        f"values (default: the one searched for --weights: {plain_preset().name} for the default weights, "
                        "tuned for --weights paper)")
    method.add_argument("--prior-from", metavar="SOURCE|FILE.npz", help=PRIOR_FROM_HELP)
    method.add_argument("--predict-budget", type=budget_seconds, default=None, metavar="SECONDS|none",
                        help="seconds the prediction may take once the model is loaded; past them the plan falls back and says so "
                        f"(default: {DEFAULT_PREDICT_BUDGET:g}; none: no limit)")
    method.add_argument("--fallback", metavar="NAME|none", default=None,
                        help="plan with this method instead of the NDR one when the model's prediction is "
                        "judged uninformative (the summary and the JSON's prediction_quality say why) "
                        f"(default: {DEFAULT_FALLBACK} for a map file with one method, none for --sample and for several methods; "
                        "with --preset spec the general model does better with none: docs/results.md#transfer)")

    g = p.add_argument_group("planning grid and path on the map")
    g.add_argument("--grid", choices=GRID_RULES, default=None,
                   help="planning-grid rule: safe (square cells, blocked if any pixel is an obstacle) or area (the "
                   "paper's >= 0.5 rule) (default: safe for a map file, area for --sample)")
    g.add_argument("--size", type=grid_size, default=None, metavar="N|auto",
                   help=f"cells on the map's longer side, or auto: the coarsest safe grid whose route stays within "
                   f"{settings.tolerance:.0%}% of the map's own shortest route (default: auto for safe, 50 for area; "
                   f"at most --max-size)")
    g.add_argument("--max-size", type=int, default=settings.max_size, metavar="N",
                   help=f"{docs['max_size']} (default: {settings.max_size})")
    g.add_argument("--robot-radius", type=float, default=None, metavar="R",
                   help=f"{docs['robot_radius']} (default: 0)")
    g.add_argument("--smooth", action=argparse.BooleanOptionalAction, default=None,
                   help="shortcut the learned path by line of sight on the full map (default: on for a map file, "
                   "off for --sample)")

    out = p.add_argument_group("output")
    out.add_argument("--json", metavar="FILE", help="write grid, start, goal, timings and every run as JSON ('-': stdout, the summary then goes to stderr)")
    out.add_argument("--records", action="store_true", help="include per-episode records in the JSON")
    out.add_argument("--png", metavar="FILE", help="write a figure: map, NDR region and guideline, learned and A* paths "
                     "(one panel per method with --compare)")
    add_dpi_argument(out)

    ros = p.add_argument_group("ROS maps (map_server .yaml: metres in the map frame)")
    ros.add_argument("--start-world", metavar="X,Y[,YAW]", help="start in metres (yaw in radians) in the map frame "
                     "(ROS maps), instead of --start; negative values as typed: --start-world -1.5,2")
    ros.add_argument("--goal-world", metavar="X,Y[,YAW]", help="goal in metres in the map frame (ROS maps), instead of --goal")
    ros.add_argument("--unknown", choices=("obstacle", "free"), default=None,
                    help="ROS maps: how unknown space counts: obstacle (map_server's reading; default) or free "
                    "(Nav2's allow_unknown: unknown to the planner and free for the learning environment, whose "
                    "truth is not known)")
    add_path_out_arguments(ros)

    add_batch_group(p, "run")

    adv = p.add_argument_group("advanced: model and speed")
    adv.add_argument("--threads", type=int, default=settings.threads, metavar="N",
                     help=f"{docs['threads']} (default: {settings.threads})")
    adv.add_argument("--backend", choices=BACKENDS, default=settings.backend,
                     help=f"{docs['backend']} (default: {settings.backend})")
    adv.add_argument("--learned-distance", action=argparse.BooleanOptionalAction, default=settings.learned_distance,
                     help=f"{docs['learned_distance']} (default: on)")
    add_symmetries_argument(adv, docs["symmetries"], settings.symmetries)
    add_constant_groups(p, _QL_FLAGS, _PRIOR_FLAGS)
    p.set_defaults(func=run)


def _set_fields(args: argparse.Namespace, names: tuple[str, ...]) -> dict[str, Any]:
    """The constants given as flags (each one set explicitly, even to its default value)."""
    return {n: getattr(args, f"cfg_{n}") for n in names if getattr(args, f"cfg_{n}") is not None}


def request_points(args: argparse.Namespace, sample: GridMapProblem | None) -> dict[str, Any]:
    """Start and goal as the flags give them (a sample's own points unless flags replace them)."""
    start = parse_point(args.start, "--start") if args.start else None
    goal = parse_point(args.goal, "--goal") if args.goal else None
    start_world = parse_world_point(args.start_world, "--start-world") if args.start_world else None
    goal_world = parse_world_point(args.goal_world, "--goal-world") if args.goal_world else None
    for flag, pixel, world in (("start", start, start_world), ("goal", goal, goal_world)):
        if pixel and world:
            raise NdrqlError(f"give --{flag} (ROW,COL pixels) or --{flag}-world (X,Y metres), not both")
    if args.scen:
        given = [f for f, v in (("--start", start), ("--goal", goal), ("--start-world", start_world),
                                ("--goal-world", goal_world)) if v is not None]
        if given:
            raise NdrqlError(f"--scen gives start and goal; drop {' and '.join(given)} (or drop --scen)")
    if sample is not None:
        start = start if start is not None or start_world else sample.start
        goal = goal if goal is not None or goal_world else sample.goal
    elif not args.scen:
        missing = [f for f, v, w in (("--start", start, start_world), ("--goal", goal, goal_world)) if v is None and w is None]
        if missing:
            raise NdrqlError(f"{' and '.join(missing)} required with a map file (ROW,COL in map pixels, or "
                             f"{' and '.join(m + '-world' for m in missing)} X,Y in metres on ROS maps), or --scen FILE")
    return {"start": start, "goal": goal, "start_world": _xyyaw(start_world), "goal_world": _xyyaw(goal_world)}


def scenario_fields(args: argparse.Namespace) -> dict[str, Any]:
    if not args.scen:
        if args.index is not None:
            raise NdrqlError("--index needs --scen FILE")
        return {}
    if args.index is None:
        return {"scen": args.scen}
    if parse_scen(args.scen)[1] is not None:
        raise NdrqlError("give the scenario as --scen FILE:K or --index K, not both")
    try:
        return {"scen": args.scen, "scen_index": int(args.index)}
    except ValueError:
        raise NdrqlError(f"--index must be a scenario number K or a range A:B, got {str(args.index)[:40]!r}") from None


def request_fields(args: argparse.Namespace, methods: list[str], seeds: Any) -> dict[str, Any]:
    """The flags as keywords of :func:`ndrql.pipeline.request.build_request` (points excluded)."""
    predictions: Any = None
    if args.prior_from in PRIOR_SOURCE_NAMES:
        predictions = args.prior_from
    elif args.prior_from:
        predictions = load_predictions(args.prior_from)
    return dict(methods=methods, seeds=list(seeds), weights=args.weights, predictions=predictions, preset=args.preset,
                ql=_set_fields(args, _QL_FLAGS), priors=_set_fields(args, _PRIOR_FLAGS), grid=args.grid, size=args.size,
                robot_radius=args.robot_radius, smooth=args.smooth, max_map_pixels=args.max_pixels, max_size=args.max_size, threads=args.threads, backend=args.backend,
                learned_distance=args.learned_distance, symmetries=args.symmetries, invert=args.invert,
                threshold=args.threshold, crop=args.crop, hide=args.hide, unknown=args.unknown,
                sense=args.sense, sense_every=args.sense_every,
                info={"prior_from": args.prior_from} if predictions is not None and not isinstance(predictions, str) else None,
                **({} if args.predict_budget is None else {"predict_budget": args.predict_budget.value}),
                **({} if args.fallback is None else {"fallback": args.fallback}))


def build_from_args(args: argparse.Namespace, methods: list[str], seeds: Any) -> Any:
    """The :class:`~ndrql.pipeline.request.PlanRequest` of ``ndrql plan``'s flags (one scenario, not a batch)."""
    sample = map_or_sample(args)
    fields = request_fields(args, methods, seeds)
    if sample is not None:
        for flag, value in (("--invert", args.invert), ("--crop", args.crop), ("--threshold", args.threshold != 128)):
            if value:
                raise NdrqlError(f"{flag} reads map files; a dataset sample has none to read")
        return build_request(sample.grid_map, **request_points(args, sample), sample=sample.info, **fields)
    scenario = scenario_fields(args)
    return build_request(args.map, **request_points(args, None), **scenario, **fields)


def _batch(args: argparse.Namespace, methods: list[str]) -> int:
    """``--all`` / ``--index A:B``: every chosen scenario with one method and one seed (:mod:`ndrql.cli.plan_batch`)."""
    if not args.scen:
        raise NdrqlError("--all and --index A:B need --scen FILE")
    bad = [f for f, v in (("--compare", args.compare), ("--start", args.start), ("--goal", args.goal),
                          ("--start-world", args.start_world), ("--goal-world", args.goal_world), ("--json", args.json),
                          ("--png", args.png), ("--path-out", args.path_out), ("--prior-from", args.prior_from),
                          ("--records", args.records)) if v]
    if bad or args.seeds != 1:
        raise NdrqlError(f"a scenario batch runs one method with one seed and writes --jsonl; drop "
                         f"{', '.join(bad) or '--seeds'}")
    if args.sample:
        raise NdrqlError("--scen needs a map file (MovingAI .map), not --sample")
    if not args.map:
        raise NdrqlError("no map given: pass MAP with --scen")
    if parse_scen(args.scen)[1] is not None:
        raise NdrqlError("give the batch range with --index A:B or --all, not --scen FILE:K")
    fields = request_fields(args, methods, [args.seed])
    with warnings_to_stderr(), warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=FallbackWarning)  # each line says which method ran
        return run_batch(args.map, args.scen, args.index, args.all, fields=fields, jsonl=args.jsonl, echo=print)


def _summary(report: Any) -> list[str]:
    """The short summary printed by ``plan`` (:func:`ndrql.cli.plan_report.summary_lines`)."""
    return summary_lines(report)


def _short(path: str) -> str:
    """``path`` relative to the working directory when it lies below it, else as given."""
    import os

    try:
        rel = os.path.relpath(path)
    except ValueError:  # another drive (Windows)
        return path
    return rel if not rel.startswith("..") else path


def _save(fig: Any, path: str) -> Any:
    return save_figure(fig, path)


def run(args: argparse.Namespace) -> int:
    import functools
    import sys
    import time

    seeds = check_seeds(args.seed, args.seeds)  # a range: --seeds is bounded, every seed below 2**63

    check_dpi(args)
    check_outputs(args.json, args.png)  # before the work: an unwritable output is one line now, not after planning
    if args.workers is not None:
        check_int(args.workers, "--workers", 1, MAX_WORKERS)
    if args.compare and args.method != "NDR-QL":
        raise NdrqlError("give either --method or --compare, not both")
    names = [n.strip() for n in (args.compare.split(",") if args.compare else [args.method]) if n.strip()]
    if not names:
        raise NdrqlError("--compare needs at least one method name")
    methods = [get_method(n).name for n in names]
    if args.records:  # every episode is kept: bounded by what it costs (ndrql.limits)
        check_records(len(seeds) * len(methods), getattr(args, "cfg_max_episodes", None) or QLConfig().max_episodes)
    if args.all or (args.index is not None and ":" in str(args.index)):
        return _batch(args, methods)
    if args.jsonl:
        raise NdrqlError("--jsonl is for scenario batches (--scen FILE --all or --index A:B); use --json")
    request = build_from_args(args, methods, seeds)
    if args.path_out and not has_world_frame(request.grid_map):
        raise NdrqlError("--path-out writes poses in metres and needs a map with a resolution and origin "
                         "(a ROS map_server .yaml); use --json for the path in pixels")
    if args.path_out and args.path_spacing is not None:
        check_finite(args.path_spacing, "--path-spacing", 0.0)
    with warnings_to_stderr(), warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=FallbackWarning)  # the summary names both methods instead
        report = run_request(request, workers=args.workers, keep_records=args.records, progress=True)
    pg = report.grid
    # with --json - the JSON owns stdout; the summary goes to stderr
    echo = functools.partial(print, file=sys.stderr if args.json == "-" else sys.stdout)
    echo(f"map: {report.grid_map.source} ({report.grid_map.height}x{report.grid_map.width}); planning grid "
         f"{pg.shape[0]}x{pg.shape[1]}, start {pg.start}, goal {pg.goal}")
    if report.info.get("prior_from") == "oracle":
        echo("model: oracle priors (the planning grid's own shortest path; a diagnostic, not a method)")
    elif report.info.get("prior_from") == "exact":
        echo("priors: exact (the planning grid's own shortest path and BFS distance, no model: on a map the planner "
             "fully knows they need no more steps than the network's; --prior-from model asks the network)")
    elif report.weights:
        turns = report.info.get("symmetries", 1)
        seen = report.info.get("model_input", {})  # the model's view, named only where it changes what it sees
        note = view_note(seen.get("view", "native"), int(seen.get("merged", 1)))
        runs = report.info.get("runs_file")
        graph = f"; runs {_short(runs)}" if runs and runs != report.weights else ""  # the file that actually runs
        companion = f"; the companion of {Path(request.weights_file or '').name} for the grids its view merges" \
            if seen.get("companion") else ""
        echo(f"model: {_short(report.weights)} ({report.info.get('backend', 'torch')}"
             f"{f', averaged over {turns} orientations of the grid' if turns > 1 else ''}"
             f"{note}{companion}){graph}; constants: preset {request.preset.name}")
    elif "prior_grid" in report.info:
        how = ("its per-cell arrays, made on this very grid, used as given" if report.info["prior_grid"] == "as given"
               else "averaged from the map's pixels onto this grid")
        echo(f"predictions: {_short(str(args.prior_from))} ({how})")
    if not report.weights or report.info.get("prior_from") in ("oracle", "exact"):  # else the model line names it
        echo(f"constants: preset {request.preset.name}")
    lines = _summary(report)
    timed = [x for x in lines if x.startswith("time (s): ")][-1:]  # printed last, with the outputs' time
    echo("\n".join(x for x in lines if x not in timed))
    t_out = time.perf_counter()
    if args.png:
        dpi = check_dpi(args)
        fig = plan_figure(report, dpi=dpi) if len(report.requested_methods) == 1 else compare_figure(report, dpi=dpi)
        echo(f"wrote {_save(fig, args.png)}")
    if args.path_out:
        spacing = report.grid_map.resolution if args.path_spacing is None else args.path_spacing
        echo(f"wrote {write_path(args.path_out, report.results[0], spacing)}")
    if args.json:  # last: its timings hold the figure's and the path's writing as "output"
        data = report.to_dict(include_records=args.records)
        wall = data.get("timings", {}).get("wall")
        if isinstance(wall, dict):
            wall["output"] = time.perf_counter() - t_out
        written = write_json(args.json, data)
        if args.json != "-":
            echo(f"wrote {written}")
    for line in timed:
        echo(with_output_time(line, time.perf_counter() - t_out))
    return 0


def with_output_time(line: str, seconds: float) -> str:
    """The summary's time line with the seconds spent writing the outputs (--png, --path-out, --json)."""
    return line[:-1] + f", output {seconds:.3f})" if line.endswith(")") else f"{line}; output {seconds:.3f}"


def _xyyaw(point: Any) -> Any:
    return None if point is None else tuple(v for v in point if v is not None)


def write_path(path: str, run: Any, spacing: float = 0.0) -> Any:
    """Write ``run``'s final path as a nav_msgs/Path (YAML for ``.yaml``/``.yml``, else JSON), poses at most
    ``spacing`` metres apart (0: the path's corners)."""
    if run.route is None or run.route.poses is None:
        seed = f" seed {run.seed}" if getattr(run, "seed", None) is not None else ""
        raise NdrqlError(f"{run.method}{seed} found no path to write to {path}")
    msg = nav_path(run.route.poses, spacing=spacing)
    if path.lower().endswith((".yaml", ".yml")):
        import yaml

        return write_text(path, yaml.safe_dump(msg, sort_keys=False, default_flow_style=None))
    return io_write_json(path, msg)
