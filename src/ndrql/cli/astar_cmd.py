"""``ndrql astar``: the optimal path on the 50x50 planning grid (or octile on the full map)."""

from __future__ import annotations

import argparse
import warnings
from typing import Any

from ndrql.cli.common import (add_dpi_argument, add_max_pixels_argument, add_problem_arguments, check_dpi,
                              check_outputs, map_info, parse_scen, resolve_problem, save_figure, warnings_to_stderr,
                              write_json)
from ndrql.cli.options import add_command
from ndrql.errors import MapFormatError
from ndrql.limits import MAX_GRID_SIZE, check_int
from ndrql.maps.astar import astar4, astar8
from ndrql.maps.grid import PLANNING_SIZE, PlanningGrid, grid_to_strings
from ndrql.maps.readers import read_movingai_scen
from ndrql.maps.scenarios import scenario_doubts
from ndrql.viz.maps import plot_endpoints, plot_occupancy, plot_path, plot_planning_result
from ndrql.viz.style import ASTAR_COLOR, legend_below

DESCRIPTION = ("Shortest path with A*. By default: 4-connected, unit moves, on the planning grid (the map "
               "area-averaged to SIZE x SIZE, a cell blocked when >= half obstacle); start and goal map to the "
               "cell containing them (snapped to the nearest free cell with a warning). With --octile: 8-connected "
               "octile A* without corner cutting on the full-resolution map.")

EXAMPLES = """examples:
  ndrql astar map.png --start 25,179 --goal 167,5 --png out/path.png --json out/path.json
  ndrql astar --sample path-planning-dataset:seen:0 --png out.png --json out.json
  ndrql astar arena.map --scen arena.map.scen:3 --octile     # MovingAI scenario 3, 8-connected
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(subparsers, "astar", help="shortest path with A* (4-connected on the planning grid)",
                    description=DESCRIPTION, examples=EXAMPLES)
    add_problem_arguments(p)
    p.add_argument("--scen", metavar="FILE[:K]", help="MovingAI .scen: take start and goal from scenario K (default 0)")
    p.add_argument("--size", type=int, default=PLANNING_SIZE, metavar="N",
                   help=f"planning grid side, 1..{MAX_GRID_SIZE} (default: {PLANNING_SIZE}, paper)")
    add_max_pixels_argument(p)
    p.add_argument("--octile", action="store_true", help="8-connected octile A* on the full-resolution map")
    p.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    p.add_argument("--png", metavar="FILE", help="write a picture of the map and the path")
    p.add_argument("--print-grid", action="store_true", help="print the planning grid with the path (S, G, *)")
    add_dpi_argument(p)
    p.set_defaults(func=run)


def _apply_scen(args: argparse.Namespace) -> tuple[Any, Any]:
    """Fill ``--start``/``--goal`` from ``--scen FILE[:K]``; returns the problem and the scenario."""
    path, k = parse_scen(args.scen)
    idx = 0 if k is None else k
    scenarios = read_movingai_scen(path)
    if not 0 <= idx < len(scenarios):
        raise MapFormatError(f"scenario {idx} not in {path}: it has scenarios 0..{len(scenarios) - 1}"
                             if scenarios else f"{path} has no scenarios")
    scen = scenarios[idx]
    for doubt in scenario_doubts([scen], args.map or "", path):
        warnings.warn(doubt, stacklevel=1)
    args.start = args.start or f"{scen.start[0]},{scen.start[1]}"
    args.goal = args.goal or f"{scen.goal[0]},{scen.goal[1]}"
    problem = resolve_problem(args)
    if problem.grid_map.shape != (scen.height, scen.width):
        raise MapFormatError(f"scenario {idx} is for a {scen.width}x{scen.height} map, {args.map} is {problem.grid_map.width}x{problem.grid_map.height}")
    return problem, scen


def run(args: argparse.Namespace) -> int:
    check_int(args.size, "--size", 1, MAX_GRID_SIZE)
    check_dpi(args)
    check_outputs(args.json, args.png)
    scen = None
    if args.scen:
        problem, scen = _apply_scen(args)
    else:
        problem = resolve_problem(args)
    return solve(problem, args, scen)


def solve(problem: Any, args: argparse.Namespace, scen: Any = None) -> int:
    """Run A* on ``problem`` (a :class:`~ndrql.cli.common.Problem`), print a summary, write JSON/PNG.

    ``args`` needs ``size``, ``octile``, ``json``, ``png`` and ``print_grid``.
    """
    grid_map = problem.grid_map
    result: dict[str, Any] = {"map": map_info(grid_map), **{k: v for k, v in problem.info.items() if k != "source"}}
    print(f"map: {grid_map.source} ({grid_map.height}x{grid_map.width}, {100 * grid_map.obstacle_ratio:.1f}% obstacles)")

    if args.octile:
        res = astar8(grid_map.obstacles, problem.start, problem.goal)
        result.update(
            connectivity=8, start=list(problem.start), goal=list(problem.goal),
            path=[list(c) for c in res.path], length=res.cost, moves=res.moves, expanded=res.expanded,
        )
        print(f"A* (8-connected octile, no corner cutting, full map): length {res.cost:.6f}, "
              f"{res.moves} moves, {res.expanded} nodes expanded")
        if scen is not None:
            result["scenario"] = {"file": args.scen, "optimal_length": scen.optimal_length}
            print(f"scenario optimal length: {scen.optimal_length:.6f}")
        if args.json:
            print(f"wrote {write_json(args.json, result)}")
        if args.png:
            def draw(ax: Any) -> None:
                plot_occupancy(ax, grid_map.obstacles)
                plot_path(ax, res.path, color=ASTAR_COLOR, label=f"octile A* ({res.cost:.1f})")[0].set_linestyle("--")
                plot_endpoints(ax, problem.start, problem.goal)
                ax.set_aspect("equal")
                ax.set_xticks([])
                ax.set_yticks([])
                legend_below(ax)
            print(f"wrote {save_figure(draw, args.png, dpi=check_dpi(args))}")
        return 0

    with warnings_to_stderr():
        pg = PlanningGrid.from_map(grid_map, problem.start, problem.goal, size=args.size)
    res = astar4(pg.blocked, pg.start, pg.goal)
    result.update(
        connectivity=4,
        planning_size=list(pg.shape),
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
    print(f"planning grid: {pg.shape[0]}x{pg.shape[1]}, {100 * pg.blocked.mean():.1f}% blocked; "
          f"start {pg.start} <- pixel {pg.source_start}, goal {pg.goal} <- pixel {pg.source_goal}")
    print(f"A* (4-connected): {res.moves} moves, {res.expanded} nodes expanded")
    print("path (planning-grid row,col): " + " ".join(f"{r},{c}" for r, c in res.path))
    if args.print_grid:
        marks = {c: "*" for c in res.path}
        marks.update({pg.start: "S", pg.goal: "G"})
        print("\n".join(grid_to_strings(pg.blocked, marks)))
    if args.json:
        print(f"wrote {write_json(args.json, result)}")
    if args.png:
        title = f"{grid_map.source}\nA* on the {pg.shape[0]}x{pg.shape[1]} planning grid: {res.moves} moves"
        print(f"wrote {save_figure(lambda ax: plot_planning_result(ax, grid_map.obstacles, pg.blocked, res.path, pg.source_start, pg.source_goal, title=title), args.png, dpi=check_dpi(args))}")
    return 0
