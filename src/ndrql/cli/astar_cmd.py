"""``ndrql astar``: the optimal path on the planning grid ``plan`` builds (or octile on the full map)."""

from __future__ import annotations

import argparse
import warnings
from typing import Any

from ndrql.cli.common import (add_dpi_argument, add_max_pixels_argument, add_problem_arguments, check_dpi,
                              check_outputs, load_sample_problem, map_info, parse_point, save_figure, use_example,
                              warnings_to_stderr, write_json)
from ndrql.cli.options import add_command, grid_size
from ndrql.errors import NdrqlError
from ndrql.limits import MAX_GRID_SIZE, MIN_GRID_SIZE
from ndrql.maps.astar import astar4, astar8
from ndrql.maps.grid import grid_to_strings
from ndrql.pipeline.problem import build_grid, grid_text
from ndrql.pipeline.request import build_request
from ndrql.pipeline.route import make_route
from ndrql.pipeline.settings import GRID_RULES
from ndrql.viz.maps import plot_endpoints, plot_occupancy, plot_path, plot_planning_result
from ndrql.viz.style import ASTAR_COLOR, legend_below

DESCRIPTION = ("Shortest path with A*. By default: 4-connected, unit moves, on the planning grid `ndrql plan` "
               "would build: on a map file the safe grid (square cells, a cell blocked when any pixel is an "
               "obstacle, after inflating obstacles by --robot-radius; --size auto picks the coarsest that keeps "
               "the route), with --sample the paper's 50x50 area grid (a cell blocked when >= half obstacle). "
               "Start and goal map to the cell containing them (moved to the nearest free cell with a warning). "
               "The output names the grid. With --octile: 8-connected octile A* without corner cutting on the "
               "full-resolution map.")

EXAMPLES = """examples:
  ndrql astar map.png --start 25,179 --goal 167,5 --png out/path.png --json out/path.json
  ndrql astar office.yaml --start 40,30 --goal 150,160 --robot-radius 0.2     # the grid plan builds
  ndrql astar --sample path-planning-dataset:seen:0 --png out.png --json out.json
  ndrql astar arena.map --scen arena.map.scen:3 --octile     # MovingAI scenario 3, 8-connected
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(subparsers, "astar", help="shortest path with A* (4-connected on plan's planning grid)",
                    description=DESCRIPTION, examples=EXAMPLES)
    add_problem_arguments(p)
    p.add_argument("--scen", metavar="FILE[:K]", help="MovingAI .scen: take start and goal from scenario K (default 0)")
    add_grid_arguments(p, "auto for safe, 50 for area")
    add_max_pixels_argument(p)
    p.add_argument("--octile", action="store_true", help="8-connected octile A* on the full-resolution map")
    p.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    p.add_argument("--png", metavar="FILE", help="write a picture of the map and the path")
    p.add_argument("--print-grid", action="store_true", help="print the planning grid with the path (S, G, *)")
    add_dpi_argument(p)
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


def run(args: argparse.Namespace) -> int:
    check_dpi(args)
    check_outputs(args.json, args.png)
    if args.octile and (args.grid or args.size is not None or args.robot_radius is not None or args.print_grid):
        raise NdrqlError("--octile plans on the full map: drop --grid, --size, --robot-radius and --print-grid")
    request = grid_request(args, grid=args.grid, size=args.size, robot_radius=args.robot_radius)
    return solve(request, args)


def _scenario(request: Any) -> dict[str, Any] | None:
    return request.info.get("scenario")


def solve(request: Any, args: argparse.Namespace) -> int:
    """Run A* on ``request``'s map and points, print a summary, write JSON/PNG.

    ``args`` needs ``octile``, ``json``, ``png``, ``print_grid`` and ``dpi``.
    """
    grid_map = request.grid_map
    start, goal = request.start, request.goal
    result: dict[str, Any] = {"map": map_info(grid_map), **{k: v for k, v in request.info.items()
                                                           if k not in ("source", "preset")}}
    print(f"map: {grid_map.source} ({grid_map.height}x{grid_map.width}, {100 * grid_map.obstacle_ratio:.1f}% obstacles)")
    scen = _scenario(request)

    if args.octile:
        res = astar8(grid_map.obstacles, start, goal)
        result.update(
            connectivity=8, start=list(start), goal=list(goal),
            path=[list(c) for c in res.path], length=res.cost, moves=res.moves, expanded=res.expanded,
        )
        print(f"A* (8-connected octile, no corner cutting, full map): length {res.cost:.6f}, "
              f"{res.moves} moves, {res.expanded} nodes expanded")
        if scen is not None:
            print(f"scenario optimal length: {scen['optimal_length']:.6f}")
        if args.json:
            print(f"wrote {write_json(args.json, result)}")
        if args.png:
            def draw(ax: Any) -> None:
                plot_occupancy(ax, grid_map.obstacles)
                plot_path(ax, res.path, color=ASTAR_COLOR, label=f"octile A* ({res.cost:.1f})")[0].set_linestyle("--")
                plot_endpoints(ax, start, goal)
                ax.set_aspect("equal")
                ax.set_xticks([])
                ax.set_yticks([])
                legend_below(ax)
            print(f"wrote {save_figure(draw, args.png, dpi=check_dpi(args))}")
        return 0

    with warnings_to_stderr():
        pg, setup = build_grid(grid_map, start, goal, request.settings)
    res = astar4(pg.blocked, pg.start, pg.goal)
    route = make_route(setup.check_map, pg, res.path, grid_map, smooth=False) if res.path else None
    result.update(
        connectivity=4,
        planning_size=list(pg.shape),
        planning_grid=setup.to_dict(pg, grid_map.resolution),
        grid=pg.to_strings(),
        start=list(pg.start),
        goal=list(pg.goal),
        source_start=list(pg.source_start),
        source_goal=list(pg.source_goal),
        snapped={"start": pg.snapped[0], "goal": pg.snapped[1]},
        path=[list(c) for c in res.path],
        length=res.moves,
        expanded=res.expanded,
    )
    if route is not None:
        result.update(path_pixels=[[round(float(a), 3), round(float(b), 3)] for a, b in route.grid_pixels],
                      collisions=[[int(i), [int(r), int(c)]] for i, (r, c) in route.collisions])
    print(grid_text(setup, pg, grid_map.resolution))
    print(f"{100 * pg.blocked.mean():.1f}% of cells blocked; start {pg.start} <- pixel {pg.source_start}, "
          f"goal {pg.goal} <- pixel {pg.source_goal}")
    print(f"A* (4-connected): {res.moves} moves, {res.expanded} nodes expanded")
    if route is not None and route.collisions:
        print(f"the path on the map crosses obstacles at {len(route.collisions)} segments (the area grid lets cells "
              f"clip obstacles; --grid safe does not)")
    print("path (planning-grid row,col): " + " ".join(f"{r},{c}" for r, c in res.path))
    if args.print_grid:
        marks = {c: "*" for c in res.path}
        marks.update({pg.start: "S", pg.goal: "G"})
        print("\n".join(grid_to_strings(pg.blocked, marks)))
    if args.json:
        print(f"wrote {write_json(args.json, result)}")
    if args.png:
        title = (f"{grid_map.source}\nA* on the {setup.rule} {pg.shape[0]}x{pg.shape[1]} planning grid: {res.moves} moves")
        def draw(ax: Any) -> None:
            plot_planning_result(ax, grid_map.obstacles, pg.blocked, res.path, pg.source_start, pg.source_goal,
                                 title=title, cell_size=pg.cell_size,
                                 path_points=None if route is None else route.grid_pixels)
        print(f"wrote {save_figure(draw, args.png, dpi=check_dpi(args))}")
    return 0
