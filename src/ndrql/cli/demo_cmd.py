"""``ndrql demo``: plan on the bundled sample map and write a picture and a JSON report.

For now this runs A* (the optimality reference) on the bundled map; it becomes the NDR-QL plan
once the model and planners exist.
"""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "demo", help="plan on the bundled sample map (writes out/demo.png, out/demo.json)",
        description="Plan on the bundled 201x201 sample map (path-planning dataset, TEST/SEEN 906) "
        "and write a picture and a JSON report.",
        epilog="example:\n  ndrql demo --out out/", formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--out", default="out", metavar="DIR", help="output folder (default: out)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ndrql.cli.astar_cmd import solve
    from ndrql.cli.common import Problem
    from ndrql.maps.bundled import bundled_sample

    sample = bundled_sample()
    problem = Problem(sample.grid_map, sample.start, sample.goal, {"source": sample.description})
    out = Path(args.out)
    options = argparse.Namespace(size=50, octile=False, print_grid=False,
                                 json=str(out / "demo.json"), png=str(out / "demo.png"))
    return solve(problem, options)
