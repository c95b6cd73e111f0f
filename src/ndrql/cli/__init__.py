"""Command-line entry point: one thin module per subcommand.

Each subcommand module exposes ``register(subparsers)`` which adds its parser and sets
``func`` (called with the parsed namespace, returns an exit code).
"""

from __future__ import annotations

import argparse
import importlib
import sys

from ndrql import __version__
from ndrql.errors import NdrqlError

#: Subcommand modules (under ``ndrql.cli``), in the order ``--help`` lists them.
SUBCOMMANDS: tuple[str, ...] = (
    "demo_cmd",
    "map_cmd",
    "astar_cmd",
    "plan_cmd",
    "train_cmd",
    "eval_cmd",
    "predict_cmd",
    "reproduce_cmd",
    "export_cmd",
)


def build_parser() -> argparse.ArgumentParser:
    """Build the full ``ndrql`` parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="ndrql",
        description="Learning-guided grid path planning (NDR-QL): NDR model, Q-learning planners, A*.",
    )
    parser.add_argument("--version", action="version", version=f"ndrql {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in SUBCOMMANDS:
        try:
            module = importlib.import_module(f"ndrql.cli.{name}")
        except ModuleNotFoundError as exc:  # a subcommand under construction must not break the others
            if exc.name == f"ndrql.cli.{name}":
                continue
            raise
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; bad input gives one line on stderr and exit code 2."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    try:
        return int(args.func(args) or 0)
    except NdrqlError as exc:
        print(f"ndrql: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("ndrql: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
