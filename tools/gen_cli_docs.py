#!/usr/bin/env python3
"""Write docs/cli.md from the CLI's own ``--help`` texts (every subcommand, nested ones included).

    .venv/bin/python tools/gen_cli_docs.py           # regenerate docs/cli.md
    .venv/bin/python tools/gen_cli_docs.py --check   # exit 1 if docs/cli.md is out of date (the test does this)

Help is rendered at a fixed width (COLUMNS=100) so the file does not depend on the terminal.
"""

from __future__ import annotations

import argparse
import difflib
import os
import sys
from pathlib import Path

DOC = Path(__file__).resolve().parents[1] / "docs" / "cli.md"
WIDTH = "100"

HEADER = """# Command-line reference

Generated from the CLI's `--help` by `tools/gen_cli_docs.py`; do not edit by hand
(`tests/product/test_docs.py` fails when this file and the CLI disagree: run
`.venv/bin/python tools/gen_cli_docs.py` to regenerate). Start with `ndrql demo`, then
`ndrql plan MAP --start ROW,COL --goal ROW,COL` on your own map.
"""


def _subparsers(parser: argparse.ArgumentParser) -> list[tuple[str, argparse.ArgumentParser]]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            seen: set[int] = set()
            out = []
            for name, sub in action.choices.items():  # aliases point to the same parser: list it once
                if id(sub) not in seen:
                    seen.add(id(sub))
                    out.append((name, sub))
            return out
    return []


def _sections(parser: argparse.ArgumentParser, prefix: str, level: int) -> list[str]:
    out = [f"{'#' * level} `{prefix}`", "", "```text", parser.format_help().rstrip(), "```", ""]
    for name, sub in _subparsers(parser):
        out += _sections(sub, f"{prefix} {name}", level + 1)
    return out


def render() -> str:
    """The whole of docs/cli.md as text."""
    os.environ["COLUMNS"] = WIDTH
    from ndrql.cli import build_parser

    parser = build_parser()
    names = [name for name, _ in _subparsers(parser)]
    lines = [HEADER, "Commands: " + ", ".join(f"[`{n}`](#ndrql-{n})" for n in names) + ".", ""]
    lines += _sections(parser, "ndrql", 2)
    lines += _batch_records()
    return "\n".join(lines).rstrip() + "\n"


def _batch_records() -> list[str]:
    """The fields of a scenario batch's ``--jsonl`` records (``plan`` and ``astar``), from the code that writes them."""
    from ndrql.cli.plan_batch import FIELD_DOCS, RECORD_FIELDS

    out = ["## Batch records (`--jsonl`)", "",
           "`ndrql plan MAP --scen FILE --all --jsonl OUT` and `ndrql astar MAP --scen FILE --all --jsonl OUT` (or "
           "`--index A:B`) append one JSON object per line and scenario, as it finishes; running the same command "
           "again skips the scenarios already in OUT. Every record has these fields in this order (a field that does "
           "not apply is `null`; `path_world`, `requested`, `fallback_reason` and `error` appear only when they "
           "apply). Read them with `pandas.read_json(OUT, lines=True)`.", "",
           "| field | meaning |", "|---|---|"]
    out += [f"| `{name}` | {FIELD_DOCS[name]} |" for name in RECORD_FIELDS]
    return out + [""]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="compare with docs/cli.md instead of writing it")
    args = ap.parse_args(argv)
    text = render()
    if args.check:
        current = DOC.read_text(encoding="utf-8") if DOC.exists() else ""
        if current != text:
            diff = difflib.unified_diff(current.splitlines(), text.splitlines(), "docs/cli.md", "CLI --help", lineterm="", n=1)
            print("\n".join(list(diff)[:60]))
            print(f"{DOC} is out of date: run .venv/bin/python tools/gen_cli_docs.py", file=sys.stderr)
            return 1
        return 0
    from ndrql.io import write_text

    write_text(DOC, text)
    print(f"wrote {DOC}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
