"""``ndrql astar``: A* as a planner in its own right, on the request ``plan`` builds (the optimal path on
plan's planning grid, or with ``--octile`` on the full map): world points, the robot's radius, a
nav_msgs/Path, scenario batches; the search is :func:`ndrql.pipeline.shortest.search` (``ndrql.astar``)."""

from __future__ import annotations

import argparse
import functools
import sys
import time
import warnings
from typing import Any

from ndrql.cli.common import (map_or_sample, add_batch_group, add_dpi_argument, add_max_pixels_argument, add_path_out_arguments,
                              add_problem_arguments, check_dpi, check_outputs, load_sample_problem, map_info,
                              parse_point, parse_scen, save_figure, use_example, warnings_to_stderr, write_json)
from ndrql.cli.plan_batch import run_batch
from ndrql.cli.plan_cmd import request_points, scenario_fields, write_path
from ndrql.cli.options import add_command, grid_size
from ndrql.errors import NdrqlError
from ndrql.limits import MAX_GRID_SIZE, MIN_GRID_SIZE, check_finite
from ndrql.maps.grid import grid_to_strings
from ndrql.maps.world import has_world_frame
from ndrql.pipeline.problem import grid_text
from ndrql.pipeline.request import build_request
from ndrql.pipeline.route import octile_cost
from ndrql.pipeline.settings import GRID_RULES
from ndrql.pipeline.shortest import AStarRun, search
from ndrql.viz.maps import plot_endpoints, plot_occupancy, plot_path, plot_planning_result
from ndrql.viz.style import ASTAR_COLOR, legend_below

DESCRIPTION = ("Shortest path with A*, on the request `ndrql plan` builds (same map reading, points, robot radius "
               "and planning grid), without learning: fast, and optimal on its grid. By default 4-connected unit "
               "moves on plan's planning grid: on a map file the safe grid (square cells, a cell blocked when any "
               "pixel is an obstacle after inflating obstacles by --robot-radius; --size auto picks the coarsest that "
               "keeps the route), with --sample the paper's 50x50 area grid. The path becomes a route on the full "
               "map as plan's does (checked, shortcut by line of sight on a map file, world poses on ROS maps). With "
               "--octile: 8-connected octile A* without corner cutting on the full-resolution map (after inflating it "
               "by --robot-radius), the MovingAI measure. Prints a summary; the path itself with --print-path, "
               "--json or --path-out.")

EXAMPLES = """examples:
  ndrql astar map.png --start 25,179 --goal 167,5 --png out/path.png --json out/path.json
  ndrql astar office.yaml --start-world 2.5,4.0 --goal-world 12.0,1.5 --robot-radius 0.2 --octile --path-out p.yaml
  ndrql astar office.yaml --start 40,30 --goal 150,160 --robot-radius 0.2     # the grid plan builds
  ndrql astar --sample path-planning-dataset:seen:0 --png out.png --json out.json
  ndrql astar arena.map --scen arena.map.scen:3 --octile                 # MovingAI scenario 3, 8-connected
  ndrql astar arena.map --scen arena.map.scen --all --octile --jsonl arena-astar.jsonl   # every scenario
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(subparsers, "astar", help="shortest path with A* (plan's grid, or octile on the full map)",
                    description=DESCRIPTION, examples=EXAMPLES)
    inp = p.add_argument_group("input: map, start and goal")
    add_problem_arguments(inp)
    inp.add_argument("--scen", metavar="FILE[:K]", help="MovingAI .scen: start and goal from scenario K (or --index K; "
                     "default 0)")
    add_max_pixels_argument(inp)
    method = p.add_argument_group("method: the search and its grid")
    method.add_argument("--octile", action="store_true", help="8-connected octile A* (no corner cutting) on the "
                        "full-resolution map, after inflating it by --robot-radius")
    add_grid_arguments(method, "auto for safe, 50 for area")
    method.add_argument("--smooth", action=argparse.BooleanOptionalAction, default=None,
                        help="shortcut the grid path by line of sight on the full map, as plan does (default: on for a "
                        "map file, off for --sample; --octile: never)")
    out = p.add_argument_group("output")
    out.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    out.add_argument("--png", metavar="FILE", help="write a picture of the map and the path")
    out.add_argument("--print-path", action="store_true", help="print the path's cells (planning grid, or map pixels "
                     "with --octile)")
    out.add_argument("--print-grid", action="store_true", help="print the planning grid with the path (S, G, *)")
    add_dpi_argument(out)
    ros = p.add_argument_group("ROS maps (map_server .yaml: metres in the map frame)")
    ros.add_argument("--start-world", metavar="X,Y[,YAW]", help="start in metres (yaw in radians), instead of --start")
    ros.add_argument("--goal-world", metavar="X,Y[,YAW]", help="goal in metres, instead of --goal")
    add_path_out_arguments(ros)

    add_batch_group(p, "search")
    p.set_defaults(func=run)


def add_grid_arguments(parser: argparse.ArgumentParser, size_default: str, rule: bool = True) -> None:
    """``--grid``, ``--size`` and ``--robot-radius``: the planning grid ``plan`` would build, for a command that
    shows or uses one (unset flags are decided by :func:`~ndrql.pipeline.request.build_request`)."""
    if rule:
        parser.add_argument("--grid", choices=GRID_RULES, default=None,
                            help="planning-grid rule: safe (a cell blocked when any pixel is an obstacle) or area "
                            "(the paper's) (default: safe for a map file, area for --sample)")
    parser.add_argument("--size", type=grid_size, default=None, metavar="N|auto",
                        help=f"cells on the map's longer side, {MIN_GRID_SIZE}..{MAX_GRID_SIZE}, or auto (safe grid: the "
                        f"coarsest that keeps the route, as plan picks it) (default: {size_default})")
    parser.add_argument("--robot-radius", type=float, default=None, metavar="R",
                        help="inflate obstacles by the robot's radius before building the grid, as plan does (metres "
                        "on maps with a resolution, else pixels) (default: 0)")


def grid_request(args: argparse.Namespace, **settings: Any) -> Any:
    """The :class:`~ndrql.pipeline.request.PlanRequest` (map, points, grid settings) of a command's map
    arguments, built as ``plan`` builds it; ``settings``: :class:`PlanSettings` fields the command sets."""
    if getattr(args, "example", False):
        use_example(args, bool(getattr(args, "sample", None)))
    if getattr(args, "sample", None) and args.map:
        raise NdrqlError("give either MAP or --sample, not both")
    scen = getattr(args, "scen", None)
    points = {"start": parse_point(args.start, "--start") if args.start else None,
              "goal": parse_point(args.goal, "--goal") if args.goal else None}
    fields = {"methods": ("QL",), "max_map_pixels": getattr(args, "max_pixels", None), **settings}
    size = settings.get("size")
    if size is not None and str(size).strip().lower() != "auto":  # a size given: the bounds every command shares
        fields["max_size"] = MAX_GRID_SIZE  # (auto keeps plan's default ceiling, so it picks plan's grid)
    if getattr(args, "sample", None):
        if scen:
            raise NdrqlError("--scen needs a map file (MovingAI .map), not --sample")
        sample = load_sample_problem(args.sample)
        points = {k: v if v is not None else getattr(sample, k) for k, v in points.items()}
        return build_request(sample.grid_map, **points, sample=sample.info, **fields)
    if not args.map:
        raise NdrqlError("no map given: pass MAP, --example (the bundled map) or --sample DATASET_DIR:SPLIT:INDEX")
    if scen:
        given = [f"--{k}" for k, v in points.items() if v is not None]
        if given:
            raise NdrqlError(f"--scen gives start and goal; drop {' and '.join(given)} (or drop --scen)")
        return build_request(args.map, scen=scen, invert=args.invert, threshold=args.threshold, crop=args.crop, **fields)
    missing = [f"--{k}" for k, v in points.items() if v is None]
    if missing:
        raise NdrqlError(f"{' and '.join(missing)} required with a map file (ROW,COL in map pixels), or --scen FILE")
    return build_request(args.map, **points, invert=args.invert, threshold=args.threshold, crop=args.crop, **fields)


def _given(args: argparse.Namespace) -> dict[str, Any]:
    """The request's settings as the flags give them (``None``: build_request decides)."""
    return dict(methods=("QL",), grid=args.grid, size=args.size, robot_radius=args.robot_radius,
                smooth=False if args.octile else args.smooth, max_map_pixels=args.max_pixels)


def astar_request(args: argparse.Namespace) -> Any:
    """The :class:`~ndrql.pipeline.request.PlanRequest` of astar's flags, built as ``plan`` builds its own."""
    sample = map_or_sample(args)
    if sample is not None:
        return build_request(sample.grid_map, **request_points(args, sample), sample=sample.info, **_given(args))
    return build_request(args.map, **request_points(args, None), **scenario_fields(args), invert=args.invert,
                         threshold=args.threshold, crop=args.crop, **_given(args))


def _check(args: argparse.Namespace) -> None:
    check_dpi(args)
    check_outputs(args.json, args.png, args.path_out)
    if args.octile and (args.grid or args.size is not None or args.print_grid or args.smooth is not None):
        raise NdrqlError("--octile searches the full map: drop --grid, --size, --smooth and --print-grid")
    if args.path_spacing is not None:
        if not args.path_out:
            raise NdrqlError("--path-spacing applies to --path-out")
        check_finite(args.path_spacing, "--path-spacing", 0.0)


def run(args: argparse.Namespace) -> int:
    _check(args)
    if args.all or (args.index is not None and ":" in str(args.index)):
        return _batch(args)
    if args.jsonl:
        raise NdrqlError("--jsonl is for scenario batches (--scen FILE --all or --index A:B); use --json")
    request = astar_request(args)
    if args.path_out and not has_world_frame(request.grid_map):
        raise NdrqlError("--path-out writes poses in metres and needs a map with a resolution and origin "
                         "(a ROS map_server .yaml); use --json for the path in pixels")
    with warnings_to_stderr():
        result = search(request, octile=args.octile)
    echo = functools.partial(print, file=sys.stderr) if args.json == "-" else print  # --json -: the JSON owns stdout
    for line in summary_lines(result):
        echo(line)
    if args.print_path:
        where = "map pixels" if args.octile else "planning-grid"
        echo(f"path ({where} row,col): " + " ".join(f"{r},{c}" for r, c in result.path))
    if args.print_grid:
        marks = {tuple(c): "*" for c in result.path}
        marks.update({result.grid.start: "S", result.grid.goal: "G"})
        echo("\n".join(grid_to_strings(result.grid.blocked, marks)))
    took = write_outputs(args, result, echo)
    echo(time_line(result, took))
    return 0


def summary_lines(result: AStarRun) -> list[str]:
    """What astar prints (at most a screen): map, grid, the search, the route on the map, the scenario's optimum."""
    request = result.request
    grid_map = request.grid_map
    res = grid_map.resolution
    lines = [f"map: {grid_map.source} ({grid_map.height}x{grid_map.width}, {100 * grid_map.obstacle_ratio:.1f}% obstacles)"]
    scen = request.info.get("scenario")
    route = result.route
    if result.grid is None:
        radius = f", obstacles inflated by {_units(result.radius_px, res)}" if result.radius_px > 0 else ""
        lines.append(f"A* (8-connected octile, no corner cutting, full map{radius}): length {result.path_length:.6f} px"
                     f"{_metres(result.path_length, res)}, {len(result.path) - 1} moves, {result.expanded} nodes expanded")
    else:
        pg, setup = result.grid, result.setup
        lines.append(grid_text(setup, pg, res))
        lines.append(f"{100 * pg.blocked.mean():.1f}% of cells blocked; start {pg.start} <- pixel {pg.source_start}, "
                     f"goal {pg.goal} <- pixel {pg.source_goal}")
        lines.append(f"A* (4-connected): {int(result.path_length)} moves, {result.expanded} nodes expanded")
        if route.collides:
            lines.append(f"the path on the map crosses obstacles at {len(route.final_collisions)} segments (the area "
                         f"grid lets cells clip obstacles; --grid safe does not)")
        else:
            what = "smoothed" if route.smoothed else "not smoothed"
            lines.append(f"path on the map collision-free; grid path {_units(route.grid_length, res)}, {what} "
                         f"{_units(route.length, res)}")
    if scen is not None:
        opt = scen["optimal_length"]
        ratio = f" (the path's octile cost {octile_cost(route.pixels) / opt:.3f}x)" if opt > 0 else ""
        lines.append(f"scenario {scen['index']} optimal length: {opt:.6f}{ratio}")
    return lines


def _units(px: float, resolution: float | None) -> str:
    return f"{px:,.1f} px" + _metres(px, resolution)


def _metres(px: float, resolution: float | None) -> str:
    return f" = {px * resolution:,.2f} m" if resolution is not None else ""


def time_line(result: AStarRun, output: float) -> str:
    """Seconds per stage, the outputs written included."""
    t = result.timings
    return (f"time (s): map {t.get('map', 0.0):.3f}, grid {t.get('grid', 0.0):.3f}, search {t.get('search', 0.0):.3f}, "
            f"route {t.get('route', 0.0):.3f}, output {output:.3f}")


def result_dict(result: AStarRun) -> dict[str, Any]:
    """The JSON astar writes: the map, the request's record, the search and its route, the grid when there is one."""
    request = result.request
    out: dict[str, Any] = {"map": map_info(request.grid_map),
                           **{k: v for k, v in request.info.items() if k not in ("source", "preset")}}
    out.update(result.to_dict())
    out["robot_radius_px"] = round(result.radius_px, 4)
    if result.grid is None:
        out.update(start=list(request.start), goal=list(request.goal), length=result.path_length,
                   moves=len(result.path) - 1)
        return out
    pg = result.grid
    out.update(planning_size=list(pg.shape), planning_grid=result.setup.to_dict(pg, request.grid_map.resolution),
               grid=pg.to_strings(), start=list(pg.start), goal=list(pg.goal), source_start=list(pg.source_start),
               source_goal=list(pg.source_goal), snapped={"start": pg.snapped[0], "goal": pg.snapped[1]},
               length=int(result.path_length),
               path_pixels=[[round(float(a), 3), round(float(b), 3)] for a, b in result.route.grid_pixels],
               collisions=[[int(i), [int(r), int(c)]] for i, (r, c) in result.route.final_collisions])
    return out


def write_outputs(args: argparse.Namespace, result: AStarRun, echo: Any) -> float:
    """Write --png, --path-out and --json (in that order: the JSON's timings include the others); their seconds."""
    t0 = time.perf_counter()
    if args.png:
        echo(f"wrote {_figure(args, result)}")
    if args.path_out:
        spacing = result.request.grid_map.resolution if args.path_spacing is None else args.path_spacing
        echo(f"wrote {write_path(args.path_out, result, spacing)}")
    if args.json:
        data = result_dict(result)
        data["timings"]["output"] = round(time.perf_counter() - t0, 6)
        written = write_json(args.json, data)
        if args.json != "-":
            echo(f"wrote {written}")
    return time.perf_counter() - t0


def _figure(args: argparse.Namespace, result: AStarRun) -> Any:
    grid_map = result.request.grid_map
    start, goal = result.request.start, result.request.goal
    if result.grid is None:
        def draw(ax: Any) -> None:
            plot_occupancy(ax, grid_map.obstacles)
            plot_path(ax, result.path, color=ASTAR_COLOR, label=f"octile A* ({result.path_length:.1f})")[0].set_linestyle("--")
            plot_endpoints(ax, start, goal)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            legend_below(ax)
        return save_figure(draw, args.png, dpi=check_dpi(args))
    pg, setup = result.grid, result.setup
    title = f"{grid_map.source}\nA* on the {setup.rule} {pg.shape[0]}x{pg.shape[1]} planning grid: {int(result.path_length)} moves"

    def draw_grid(ax: Any) -> None:
        plot_planning_result(ax, grid_map.obstacles, pg.blocked, [tuple(c) for c in result.path], pg.source_start,
                             pg.source_goal, title=title, cell_size=pg.cell_size, path_points=result.route.pixels)
    return save_figure(draw_grid, args.png, dpi=check_dpi(args))


def _batch(args: argparse.Namespace) -> int:
    """``--all`` / ``--index A:B``: every chosen scenario searched with A* (:mod:`ndrql.cli.plan_batch`)."""
    if not args.scen:
        raise NdrqlError("--all and --index A:B need --scen FILE")
    bad = [f for f, v in (("--start", args.start), ("--goal", args.goal), ("--start-world", args.start_world),
                          ("--goal-world", args.goal_world), ("--json", args.json), ("--png", args.png),
                          ("--path-out", args.path_out), ("--print-path", args.print_path),
                          ("--print-grid", args.print_grid), ("--sample", args.sample),
                          ("--example", args.example)) if v]
    if bad:
        raise NdrqlError(f"a scenario batch writes one line per scenario and --jsonl; drop {', '.join(bad)}")
    if not args.map:
        raise NdrqlError("no map given: pass MAP with --scen")
    if parse_scen(args.scen)[1] is not None:
        raise NdrqlError("give the batch range with --index A:B or --all, not --scen FILE:K")
    fields = dict(_given(args), seeds=(0,), invert=args.invert, threshold=args.threshold, crop=args.crop)
    with warnings_to_stderr(), warnings.catch_warnings():
        return run_batch(args.map, args.scen, args.index, args.all, fields=fields, jsonl=args.jsonl, echo=print,
                         astar="A*-octile" if args.octile else "A*")
