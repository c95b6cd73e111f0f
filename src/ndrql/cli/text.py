"""Text for the terminal: help without docstring markup, a one-line usage for errors, aligned tables.

Subcommand descriptions and flag help come from docstrings written for Sphinx-style rendering
(``None``, ``:class:`~ndrql.x.Y```, ``Example::``). :func:`plain` turns that into plain text for
``--help`` (and for ``docs/cli.md``, which is generated from it).
"""

from __future__ import annotations

import argparse
import re
from typing import Any, Sequence

from ndrql.version import DOCS_URL

_ROLE = re.compile(r":(?:class|func|meth|mod|data|attr|exc|obj):`~?([^`<]+?)`")
_LITERAL = re.compile(r"``([^`]+)``")
_BLOCK = re.compile(r"(\S)::(\s*\n)")


#: A page of the repository's docs folder named in help text (``docs/method.md``, ``docs/results.md#transfer``).
_DOCS_PAGE = re.compile(r"(?<![\w/.])docs/([\w-]+\.md(?:#[\w-]+)?)")


def plain(text: str) -> str:
    """``text`` without reST markup: roles become their name, ````x```` becomes ``x``, ``Example::`` ``Example:``;
    a ``docs/PAGE.md`` becomes its address online (:data:`~ndrql.version.DOCS_URL`: a pip install has no docs folder)."""
    text = _DOCS_PAGE.sub(lambda m: f"{DOCS_URL}/{m.group(1)}", text)
    text = _ROLE.sub(lambda m: m.group(1).rsplit(".", 1)[-1], text)
    text = _LITERAL.sub(r"\1", text)
    text = _BLOCK.sub(r"\1:\2", text)
    return re.sub(r"(?m)^(\s*)::\s*$", "", text)


def _positional_usage(action: argparse.Action) -> str:
    name = action.metavar if isinstance(action.metavar, str) else action.dest.upper()
    if action.nargs == "?":
        return f"[{name}]"
    if action.nargs == "*":
        return f"[{name} ...]"
    if action.nargs == "+":
        return f"{name} [{name} ...]"
    if action.nargs in (argparse.PARSER, argparse.REMAINDER):
        return f"{name} ..."
    return name


def short_usage(parser: argparse.ArgumentParser) -> str:
    """``usage: PROG [options] POSITIONALS`` in one short line (the full usage of ``plan`` runs to 20 lines)."""
    positionals = [_positional_usage(a) for a in parser._actions if not a.option_strings]
    return " ".join(["usage:", parser.prog, "[options]", *positionals])


def text_table(header: Sequence[str], rows: Sequence[Sequence[Any]], align: str | None = None, gap: int = 2) -> list[str]:
    """Lines of a plain-text table whose columns are as wide as their widest cell, ``gap`` spaces apart.

    ``align`` has one letter per column, ``l`` or ``r`` (default: first left, the rest right), so
    numbers of any size (an 8-digit step count, a wide interval) never run into the next column.
    A rule of ``-`` follows the header.
    """
    cells = [[str(h) for h in header]] + [[str(c) for c in row] for row in rows]
    n = len(header)
    if any(len(row) != n for row in cells):
        raise ValueError(f"every row needs {n} cells like the header")
    align = align or "l" + "r" * (n - 1)
    widths = [max(len(row[i]) for row in cells) for i in range(n)]
    sep = " " * gap

    def line(row: list[str]) -> str:
        return sep.join(c.ljust(w) if a == "l" else c.rjust(w) for c, w, a in zip(row, widths, align)).rstrip()

    out = [line(cells[0]), "-" * (sum(widths) + gap * (n - 1))]
    return out + [line(row) for row in cells[1:]]


#: C0 and C1 control characters but tab and newline, as ``\\xNN``: what a file name or a map's own text can hold.
_CONTROL = {c: f"\\x{c:02x}" for c in (*range(0x00, 0x09), *range(0x0b, 0x20), 0x7f, *range(0x80, 0xa0))}


def escape_controls(text: str) -> str:
    """``text`` with control characters (escape sequences, carriage returns, bells) written as ``\\xNN``."""
    return text.translate(_CONTROL)


class EscapedStream:
    """Standard output for the CLI: everything written is escaped once, here (:func:`escape_controls`), so a
    map named with terminal escape sequences cannot retitle, recolour or overwrite the terminal."""

    def __init__(self, raw: Any) -> None:
        self._raw = raw

    def write(self, text: str) -> int:
        self._raw.write(escape_controls(text))
        return len(text)

    def __getattr__(self, name: str) -> Any:  # flush, fileno, isatty, buffer, encoding, ...
        return getattr(self._raw, name)
