"""Command-line entry point: one thin module per subcommand.

Each subcommand module exposes ``register(subparsers)`` which adds its parser and sets
``func`` (called with the parsed namespace, returns an exit code).

Every error is one line on stderr and exit code 2: bad flags (no usage dump), any
:class:`~ndrql.errors.NdrqlError`, a ``ValueError``/``OverflowError`` from the library (a value
out of range), and a torch-only command run without torch (what to install). Messages are cut to
:data:`MAX_MESSAGE` characters, so no input is echoed unbounded.
Warnings from anywhere print as one ``ndrql: warning: ...`` line each.
"""

from __future__ import annotations

import argparse
import importlib
import re
import sys
from typing import NoReturn

from ndrql.cli.options import check_flags
from ndrql.cli.outputs import guard
from ndrql.io.readset import run_inputs
from ndrql.cli.text import EscapedStream, plain, short_usage
from ndrql.version import __version__
from ndrql.errors import NdrqlError, torch_missing

#: Subcommand modules (under ``ndrql.cli``), in the order ``--help`` lists them.
SUBCOMMANDS: tuple[str, ...] = (
    "demo_cmd",
    "map_cmd",
    "astar_cmd",
    "plan_cmd",
    "data_cmd",
    "train_cmd",
    "eval_cmd",
    "predict_cmd",
    "reproduce_cmd",
    "tune_cmd",
    "export_cmd",
)


#: Longest error message printed (characters); longer ones are cut with "...".
MAX_MESSAGE = 400


def one_line(message: object) -> str:
    """``message`` on one line of at most :data:`MAX_MESSAGE` characters, control characters escaped
    (a file name from a map file cannot retitle or recolour the terminal)."""
    text = " ".join(str(message).split())
    if not text.isprintable():
        text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
    return text if len(text) <= MAX_MESSAGE else text[:MAX_MESSAGE - 3] + "..."


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (the error, then this parser's usage in short);
    its help is plain text (no docstring markup). Subcommand parsers inherit it."""

    def error(self, message: str) -> "NoReturn":  # type: ignore[override]
        self.exit(2, f"ndrql: error: {one_line(message)} ({short_usage(self)}; see {self.prog} --help)\n")

    def format_help(self) -> str:
        return plain(super().format_help())


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """Build the ``ndrql`` parser with every subcommand registered, or only ``command``'s when its module is
    ``<command>_cmd`` (start-up time: ``ndrql plan`` need not import the training and tuning commands)."""
    parser = _Parser(
        prog="ndrql",
        description="Learning-guided grid path planning (NDR-QL): NDR model, Q-learning planners, A*.",
    )
    parser.add_argument("--version", action="version", version=f"ndrql {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    only = f"{command}_cmd" if command else None
    for name in (only,) if only in SUBCOMMANDS else SUBCOMMANDS:
        try:
            module = importlib.import_module(f"ndrql.cli.{name}")  # lazy: subcommands by name
        except ModuleNotFoundError as exc:  # a subcommand under construction must not break the others
            if exc.name == f"ndrql.cli.{name}":
                continue
            raise
        module.register(sub)
    return parser


#: A value list that starts with a minus sign, such as a world point ``-1.925,4.625`` (argparse takes any
#: other token starting with ``-`` for a flag and says "expected one argument").
_NEGATIVE_LIST = re.compile(r"^-(\d|\.\d)[\d.eE+-]*(,\s*[-+]?[\d.eE+-]+)+$")


def join_negative_values(argv: list[str]) -> list[str]:
    """``--flag -1.9,4.6`` as ``--flag=-1.9,4.6``, so that coordinates are taken as users type them."""
    out: list[str] = []
    for tok in argv:
        if out and _NEGATIVE_LIST.match(tok) and out[-1].startswith("--") and "=" not in out[-1]:
            out[-1] = f"{out[-1]}={tok}"
        else:
            out.append(tok)
    return out


def _format_warning(message: object, category: type, filename: str, lineno: int, line: str | None = None) -> str:
    return f"ndrql: warning: {one_line(message)}\n"


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; bad input gives one line on stderr and exit code 2, a warning one ``ndrql: warning:`` line.

    Ctrl-C gives ``ndrql: interrupted`` and exit code 130 (also inside the compiled kernel, where it
    surfaces as a ``SystemError``); outputs are written atomically, so they stay as they were. A
    closed pipe on stdout exits quietly (141); any other error writing (a full disk, a closed
    stdout) is one line, exit code 2. Warnings from other libraries (numpy, torch) are held back
    and shown after a successful run, so an error is the only line a failed command prints.
    """
    import warnings

    warnings.formatwarning = _format_warning  # the CLI's own output format; the library only warns
    parser = args = None
    try:  # the one door: parsing, argparse's type functions, the environment and the notice too
        argv = join_negative_values(sys.argv[1:] if argv is None else list(argv))
        parser = build_parser(argv[0] if argv else None)
        args, extra = parser.parse_known_args(argv)
        if extra:  # the subcommand's parser reports flags it does not know, with its own usage
            chosen = _chosen_parser(parser, args)
            chosen.error(f"unrecognized arguments: {' '.join(extra)}")
        if not getattr(args, "func", None):
            parser.print_help()
            return 0
        if args.command in COMPILING_COMMANDS:
            _compile_notice()
    except SystemExit:
        raise
    except BaseException as exc:  # noqa: BLE001 - every failure becomes one line
        return _door(exc, parser, args)
    held: list[str] = []
    shown_before = warnings.showwarning

    def show(message: object, category: type, filename: str, lineno: int, file: object = None, line: object = None) -> None:
        text = _format_warning(message, category, filename, lineno)
        if _ours(filename):
            sys.stderr.write(text)
        elif text not in held:
            held.append(text)

    warnings.showwarning = show
    stdout = sys.stdout
    try:
        sys.stdout = EscapedStream(stdout) if stdout is not None else None  # type: ignore[assignment]
        with run_inputs():  # the files this command reads, which no output may replace
            code = _run(parser, args)
    finally:
        sys.stdout = stdout
        warnings.showwarning = shown_before
    if code == 0:
        sys.stderr.write("".join(held))
    return code


def _ours(filename: str) -> bool:
    """Whether a warning comes from ndrql's own code (shown at once) rather than a library's."""
    import os

    return f"{os.sep}ndrql{os.sep}" in str(filename)


def _interrupted(exc: BaseException) -> bool:
    """Ctrl-C, also when compiled code turned it into a ``SystemError`` (its cause or context)."""
    seen = 0
    while exc is not None and seen < 16:
        if isinstance(exc, KeyboardInterrupt):
            return True
        exc = exc.__cause__ or exc.__context__  # type: ignore[assignment]
        seen += 1
    return False


def _error(message: object, code: int = 2) -> int:
    print(f"ndrql: error: {one_line(message)}", file=sys.stderr)
    return code


def _run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    """Check the numbers and the outputs, run the subcommand; every failure goes through :func:`_door`."""
    try:
        check_flags(_chosen_parser(parser, args), args)  # every number against ndrql.limits.BOUNDS
        guard(args)  # every output checked against every input and each other, before any work
        code = int(args.func(args) or 0)
        if sys.stdout is not None:
            sys.stdout.flush()
        return code
    except SystemExit:
        raise
    except BaseException as exc:  # noqa: BLE001 - every failure becomes one line
        return _door(exc, parser, args)


def _door(exc: BaseException, parser: argparse.ArgumentParser | None, args: argparse.Namespace | None) -> int:
    """The one door: any failure as one line on stderr and its exit code (NDRQL_DEBUG=1 re-raises a bug)."""
    if isinstance(exc, BrokenPipeError):  # `ndrql ... | head`: the reader left; stop quietly like other Unix tools
        _silence_stdout()
        return 141
    if isinstance(exc, KeyboardInterrupt) or _interrupted(exc):  # also inside compiled code (a SystemError)
        print("ndrql: interrupted", file=sys.stderr)
        return 130
    if isinstance(exc, (NdrqlError, ValueError, OverflowError)):
        return _error(exc)
    if isinstance(exc, RecursionError):
        return _error("the input is nested too deeply to read")
    if isinstance(exc, ImportError) and (exc.name or "torch").split(".")[0] == "torch":  # a light install: what to install
        target = getattr(args, "target", None)  # reproduce TARGET
        what = _chosen_parser(parser, args).prog if parser is not None and args is not None else "this command"
        return _error(torch_missing(what + (f" {target}" if isinstance(target, str) else "")))
    if isinstance(exc, MemoryError):
        return _error("out of memory", 1)
    if isinstance(exc, OSError):  # writing stdout on a full disk, a file vanishing under us, ...
        _silence_stdout()
        where = f" ({exc.filename})" if getattr(exc, "filename", None) else " (standard output)"
        return _error(f"cannot go on: {exc.strerror or type(exc).__name__}{where}")
    import os

    if os.environ.get("NDRQL_DEBUG"):
        raise exc
    return _error(f"internal error ({type(exc).__name__}: {exc}); please report it with the command "
                  f"(NDRQL_DEBUG=1 shows where)", 1)


#: Subcommands that run the compiled planners; on the first run after install they say that they compile.
COMPILING_COMMANDS = frozenset({"plan", "demo"})


def _compile_notice() -> None:
    """One stderr line when this run has to compile the planners (the first after install), else nothing."""
    from ndrql.planning.compiled import compile_notice  # lazy: numba's kernels only (the C ones compile nothing)

    notice = compile_notice()
    if notice:
        print(f"ndrql: {notice}", file=sys.stderr, flush=True)


def _chosen_parser(parser: argparse.ArgumentParser, args: argparse.Namespace) -> argparse.ArgumentParser:
    """The (sub)parser that parsed ``args``: follows ``command`` and nested subcommands, else ``parser``."""
    current = parser
    while True:
        subs = [a for a in current._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs:
            return current
        chosen = getattr(args, subs[0].dest or "", None)
        if chosen not in subs[0].choices:
            return current
        current = subs[0].choices[chosen]


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush cannot raise BrokenPipeError again."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass


if __name__ == "__main__":
    sys.exit(main())
