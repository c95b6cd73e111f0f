"""``ndrql map``: inspect and convert maps (``info``, ``convert``)."""

from __future__ import annotations

import argparse

from ndrql.cli.astar_cmd import add_grid_arguments, grid_request
from ndrql.cli.common import (add_map_arguments, add_max_pixels_argument, add_problem_arguments,
                              load_map_argument, map_info, warnings_to_stderr, write_json)
from ndrql.cli.options import add_command
from ndrql.errors import NdrqlError
from ndrql.limits import MAX_GRID_SIZE
from ndrql.maps.grid import PLANNING_SIZE
from ndrql.maps.problem import GridMapProblem
from ndrql.pipeline.problem import build_grid, grid_text, map_grid
from ndrql.pipeline.request import request_settings
from ndrql.maps.writers import save_map

EXAMPLES = """examples:
  ndrql map info warehouse.yaml --crop
  ndrql map info apartment.yaml --start 40,30 --goal 150,160 --robot-radius 0.15   # the grid plan builds
  ndrql map info --sample path-planning-dataset:unseen:950
  ndrql map convert arena.map arena.png
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(subparsers, "map", help="inspect or convert a map", description="Inspect or convert a map.",
                    examples=EXAMPLES)
    sub = p.add_subparsers(dest="map_command", metavar="ACTION", required=True)

    info = sub.add_parser(
        "info", help="size, obstacle ratio and the planning grid as text",
        description="Print the map's size, obstacle ratio and its planning grid (# blocked, . free): the grid "
        "`ndrql plan` builds (on a map file the safe grid, square cells blocked when any pixel is an obstacle, "
        "size auto when --start and --goal are given; with --sample the paper's 50x50 area grid). The output "
        "names the grid.",
    )
    add_problem_arguments(info)
    add_max_pixels_argument(info)
    add_grid_arguments(info, f"auto with --start and --goal, else {PLANNING_SIZE}")
    info.add_argument("--json", metavar="FILE", help="also write the information as JSON ('-' for stdout)")
    info.set_defaults(func=run_info)

    conv = sub.add_parser(
        "convert", help="convert a map to .png or .npy",
        description="Read any supported map and write it as .png (black = obstacle) or .npy (bool, True = obstacle).",
    )
    add_map_arguments(conv, map_required=True)
    add_max_pixels_argument(conv)
    conv.add_argument("output", metavar="OUTPUT", help="output file, .png or .npy")
    conv.set_defaults(func=run_convert)


def run_info(args: argparse.Namespace) -> int:
    sample = bool(args.sample)
    has_points = sample or bool(args.start and args.goal) or bool(getattr(args, "scen", None))
    if not has_points and (args.start or args.goal):
        raise NdrqlError("give both --start and --goal (the grid plan builds for them), or neither")
    if has_points:
        request = grid_request(args, grid=args.grid, size=args.size, robot_radius=args.robot_radius)
        grid_map, settings = request.grid_map, request.settings
        with warnings_to_stderr():
            pg, setup = build_grid(grid_map, request.start, request.goal, settings)
        blocked, named = pg.blocked, grid_text(setup, pg, grid_map.resolution)
    else:
        if args.size is not None and str(args.size).strip().lower() == "auto":
            raise NdrqlError("--size auto picks the grid for a route: give --start and --goal")
        loaded = load_map_argument(args)
        grid_map = loaded.grid_map if isinstance(loaded, GridMapProblem) else loaded
        settings = request_settings(grid=args.grid, size=PLANNING_SIZE if args.size is None else args.size,
                                    robot_radius=args.robot_radius, max_map_pixels=args.max_pixels,
                                    max_size=MAX_GRID_SIZE)
        blocked, named = map_grid(grid_map, settings)
        pg = setup = None
    info = map_info(grid_map)
    rows = ["".join("#" if b else "." for b in row) for row in blocked]
    print(f"map: {grid_map.source}")
    print(f"size: {grid_map.height} rows x {grid_map.width} cols")
    print(f"obstacles: {100 * grid_map.obstacle_ratio:.2f}%")
    if grid_map.resolution is not None:
        print(f"resolution: {grid_map.resolution} m/px, origin: {list(grid_map.origin or ())}")
    if sample:
        print(f"sample start: {request.start}, goal: {request.goal} (row, col), "
              f"category: {request.info['sample']['category']}")
        info.update({k: v for k, v in request.info.items() if k not in ("source", "preset")},
                    start=list(request.start), goal=list(request.goal))
    print(f"{named}; {100 * blocked.mean():.1f}% blocked:")
    print("\n".join(rows))
    if args.json:
        info.update(planning_size=list(blocked.shape), grid=rows, grid_rule=settings.grid)
        if pg is not None:
            info["planning_grid"] = setup.to_dict(pg, grid_map.resolution)
        write_json(args.json, info)
    return 0


def run_convert(args: argparse.Namespace) -> int:
    grid_map = load_map_argument(args)
    out = save_map(grid_map, args.output)
    print(f"wrote {out} ({grid_map.height}x{grid_map.width})")
    return 0
