"""``ndrql map``: inspect and convert maps (``info``, ``convert``)."""

from __future__ import annotations

import argparse

from ndrql.cli.common import (Problem, add_map_arguments, add_max_pixels_argument, load_map_argument, map_info,
                              write_json)
from ndrql.cli.options import add_command
from ndrql.limits import MAX_GRID_SIZE, check_int
from ndrql.maps.grid import PLANNING_SIZE, planning_grid
from ndrql.maps.writers import save_map

EXAMPLES = """examples:
  ndrql map info warehouse.yaml --crop
  ndrql map info --sample path-planning-dataset:unseen:950
  ndrql map convert arena.map arena.png
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(subparsers, "map", help="inspect or convert a map", description="Inspect or convert a map.",
                    examples=EXAMPLES)
    sub = p.add_subparsers(dest="map_command", metavar="ACTION", required=True)

    info = sub.add_parser(
        "info", help="size, obstacle ratio and the planning grid as text",
        description="Print the map's size, obstacle ratio and its planning grid (# blocked, . free).",
    )
    add_map_arguments(info)
    add_max_pixels_argument(info)
    info.add_argument("--size", type=int, default=PLANNING_SIZE, metavar="N",
                      help=f"planning grid side, 1..{MAX_GRID_SIZE} (default: {PLANNING_SIZE})")
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
    check_int(args.size, "--size", 1, MAX_GRID_SIZE)
    loaded = load_map_argument(args)
    grid_map = loaded.grid_map if isinstance(loaded, Problem) else loaded
    info = map_info(grid_map)
    blocked = planning_grid(grid_map, args.size)
    rows = ["".join("#" if b else "." for b in row) for row in blocked]
    print(f"map: {grid_map.source}")
    print(f"size: {grid_map.height} rows x {grid_map.width} cols")
    print(f"obstacles: {100 * grid_map.obstacle_ratio:.2f}%")
    if grid_map.resolution is not None:
        print(f"resolution: {grid_map.resolution} m/px, origin: {list(grid_map.origin or ())}")
    if isinstance(loaded, Problem):
        print(f"sample start: {loaded.start}, goal: {loaded.goal} (row, col), category: {loaded.info['sample']['category']}")
        info.update(loaded.info, start=list(loaded.start), goal=list(loaded.goal))
    print(f"planning grid {blocked.shape[0]}x{blocked.shape[1]} ({100 * blocked.mean():.1f}% blocked):")
    print("\n".join(rows))
    if args.json:
        info.update(planning_size=list(blocked.shape), grid=rows)
        write_json(args.json, info)
    return 0


def run_convert(args: argparse.Namespace) -> int:
    grid_map = load_map_argument(args)
    out = save_map(grid_map, args.output)
    print(f"wrote {out} ({grid_map.height}x{grid_map.width})")
    return 0
