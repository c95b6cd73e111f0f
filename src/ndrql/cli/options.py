"""Options shared by the subcommands: how a subcommand is declared, the seeds and workers of a planning
command, and a frozen config dataclass turned into CLI flags (one per field, help from the field's docstring)."""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
import json
from typing import Any

from ndrql.errors import NdrqlError
from ndrql.limits import bound_for, check_bound
from ndrql.pipeline.settings import MAX_PREDICT_BUDGET
from ndrql.planning.config import field_docs


def add_command(subparsers: argparse._SubParsersAction, name: str, *, help: str, description: str,
                examples: str | None = None) -> argparse.ArgumentParser:
    """A subcommand whose ``--help`` keeps the description's and the examples' line breaks (examples last)."""
    return subparsers.add_parser(name, help=help, description=description, epilog=examples,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)


def grid_size(text: str) -> int | str:
    """``--size N|auto``: an integer or ``auto`` (argparse says ``invalid grid_size value`` otherwise; the bounds
    are checked with the request, :class:`~ndrql.pipeline.settings.PlanSettings`)."""
    if str(text).strip().lower() == "auto":
        return "auto"
    if len(str(text)) > 12:
        raise ValueError("too long")
    return int(text)


def add_seed_options(parser: argparse.ArgumentParser, *, seeds: int, seeds_help: str, workers: int | None) -> None:
    """``--seeds N`` (``seeds_help``), ``--seed S`` (the first seed: runs use seeds S..S+N-1) and ``--workers N``
    (default ``workers``; ``None``: all cores)."""
    parser.add_argument("--seeds", type=int, default=seeds, metavar="N", help=seeds_help)
    parser.add_argument("--seed", type=int, default=0, metavar="S", help="first seed (default: 0)")
    parser.add_argument("--workers", type=int, default=workers, metavar="N",
                        help=f"parallel workers (default: {'all cores' if workers is None else workers})")


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
            parser.add_argument(flag, dest=f.name, type=json_value, default=None, help=help_text + " as JSON")
        else:
            parser.add_argument(flag, dest=f.name, type=type(default), default=None, help=help_text)


def dataclass_from_args(cls: type, args: argparse.Namespace, **extra: Any):
    """Build ``cls`` from parsed flags, keeping defaults for flags not given."""
    kwargs = {f.name: getattr(args, f.name) for f in dataclasses.fields(cls) if getattr(args, f.name, None) is not None}
    kwargs.update(extra)
    return cls(**kwargs)


def add_config_flags(group: argparse._ArgumentGroup, cls: type, names: tuple[str, ...],
                     shown: dict[str, str] | None = None) -> None:
    """Add ``--name`` (dest ``cfg_<name>``, numeric) for the chosen fields of a config dataclass; ``shown``:
    the default text per field when it is not the dataclass's (a preset's values, :mod:`ndrql.cli.plan_help`)."""
    docs = field_docs(cls)
    defaults = cls()
    types = {f.name: f.type for f in dataclasses.fields(cls)}
    for name in names:
        default = getattr(defaults, name)
        kind = int if "int" in str(types[name]) else float
        text = (shown or {}).get(name, "4 x cells" if default is None else default)
        group.add_argument(f"--{name.replace('_', '-')}", dest=f"cfg_{name}", type=kind, default=None,
                           metavar="V", help=f"{docs[name]} (default: {text})")


def configs_from_flags(args: argparse.Namespace, specs: tuple[tuple[type, tuple[str, ...]], ...]) -> list:
    """Build each config class from its ``cfg_<name>`` flags; a bad value is one clear NdrqlError."""
    out = []
    for cls, names in specs:
        kwargs = {n: getattr(args, f"cfg_{n}") for n in names if getattr(args, f"cfg_{n}") is not None}
        try:
            out.append(cls(**kwargs))
        except ValueError as exc:
            raise NdrqlError(f"bad option: {exc}") from None
    return out


def json_value(text: str) -> Any:
    """A flag's JSON value; argparse reports a bad one as ``invalid json_value value`` on one line (too deep a
    nesting too, never a traceback)."""
    if len(text) > 100_000:
        raise argparse.ArgumentTypeError("longer than 100,000 characters")
    try:
        return json.loads(text)
    except RecursionError:
        raise argparse.ArgumentTypeError("nested too deeply") from None


def numeric_values(value: Any) -> list[float]:
    """The numbers in a parsed flag's value (one, or a list of them); none for text, flags and ``None``."""
    values = value if isinstance(value, (list, tuple)) else [value]
    return [v for v in values if isinstance(v, (int, float)) and not isinstance(v, bool)]


def check_flags(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Every numeric flag of ``parser``'s command against :data:`ndrql.limits.BOUNDS` (``ValueError`` naming the
    flag, its range and why), before the command does any work; flags with ``choices`` are bounded by them."""
    command = parser.prog.split(" ", 1)[1] if " " in parser.prog else ""
    for action in parser._actions:
        if not action.option_strings or action.choices is not None:
            continue
        numbers = numeric_values(getattr(args, action.dest, None))
        bound = bound_for(action.option_strings[-1], command) if numbers else None
        for v in numbers if bound is not None else ():
            check_bound(v, bound, action.option_strings[-1])


@dataclass(frozen=True)
class Budget:
    """A parsed ``--predict-budget``: seconds, or ``None`` for no limit."""

    value: float | None


def budget_seconds(text: str) -> Budget:
    """``--predict-budget``: seconds in (0, 3600] or ``none``."""
    if text.strip().lower() == "none":
        return Budget(None)
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"seconds or none, got {text[:40]!r}") from None
    if not 0 < v <= MAX_PREDICT_BUDGET:  # NaN fails too
        raise argparse.ArgumentTypeError(f"seconds in (0, {MAX_PREDICT_BUDGET:g}] or none, got {text[:40]!r}")
    return Budget(v)
