"""Turn a frozen config dataclass into CLI flags (one per field, help from the field's docstring)."""

from __future__ import annotations

import argparse
import ast
import dataclasses
import inspect
import json
from typing import Any


def field_docs(cls: type) -> dict[str, str]:
    """Docstrings written under each dataclass field (the attribute-docstring convention)."""
    try:
        tree = ast.parse(inspect.getsource(cls))
    except (OSError, TypeError):
        return {}
    docs: dict[str, str] = {}
    body = tree.body[0].body  # type: ignore[attr-defined]
    for node, nxt in zip(body, body[1:]):
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            if isinstance(nxt, ast.Expr) and isinstance(getattr(nxt, "value", None), ast.Constant) and isinstance(nxt.value.value, str):
                docs[node.target.id] = nxt.value.value.strip()
    return docs


def add_dataclass_options(parser: argparse.ArgumentParser, cls: type, skip: tuple[str, ...] = ()) -> None:
    """Add ``--field-name`` for each field of ``cls`` with its default and docstring."""
    docs = field_docs(cls)
    defaults = cls()
    for f in dataclasses.fields(cls):
        if f.name in skip:
            continue
        default = getattr(defaults, f.name)
        flag = "--" + f.name.replace("_", "-")
        help_text = f"{docs.get(f.name, '')} (default: {default})"
        if isinstance(default, bool):
            parser.add_argument(flag, dest=f.name, action=argparse.BooleanOptionalAction, default=None, help=help_text)
        elif isinstance(default, dict):
            parser.add_argument(flag, dest=f.name, type=json.loads, default=None, help=help_text + " as JSON")
        else:
            parser.add_argument(flag, dest=f.name, type=type(default), default=None, help=help_text)


def dataclass_from_args(cls: type, args: argparse.Namespace, **extra: Any):
    """Build ``cls`` from parsed flags, keeping defaults for flags not given."""
    kwargs = {f.name: getattr(args, f.name) for f in dataclasses.fields(cls) if getattr(args, f.name, None) is not None}
    kwargs.update(extra)
    return cls(**kwargs)
