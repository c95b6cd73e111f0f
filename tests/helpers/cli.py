"""Running ``ndrql`` commands, and the check every bad input gets (exit 2, one line).

:func:`run_cli` runs a command of the ``ndrql`` console script. It runs it in this process, through
``ndrql.cli.main`` (an interpreter and torch start once per test session instead of once per command),
whenever that is the same as a fresh process: the environment differs from this one in ``NDRQL_*``
variables only (ndrql reads those when a command runs) and no ``preexec_fn`` is given. ndrql's
per-process caches (``functools.lru_cache``) are emptied before each command, and the state a command may
change in this process (working folder, environment, warning filters, random generators, torch's thread
count) is put back after it. Everything else, or ``in_process=False``, runs the real console script in a
child process (:func:`run_script`); the end-to-end tests (no torch, signals, memory caps, first-run
compilation, the entry point itself) do that. ``NDRQL_TEST_CHILD=1`` runs every command in a child
process, as the suite did before (to tell a difference between the two apart).
"""

from __future__ import annotations

import contextlib
import io
import os
import random
import subprocess
import sys
import traceback
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path

#: Seconds before a hung child process fails its test (commands are slow on a loaded machine; no timing is
#: asserted). A command run in this process has no timeout.
TIMEOUT = 600.0

#: Environment variables that may differ from this process's for a command to run in it (read at run time).
IN_PROCESS_ENV_PREFIX = "NDRQL_"


def run_cli(exe: Sequence[str], *args: object, cwd: str | Path | None = None, env: Mapping[str, str] | None = None,
            timeout: float = TIMEOUT, preexec_fn: Callable[[], None] | None = None,
            in_process: bool | None = None) -> subprocess.CompletedProcess[str]:
    """Run ``exe ARGS`` (each argument through ``str``), capturing stdout and stderr as text.

    ``exe`` is the ``ndrql_exe`` fixture (the console script of this environment); ``env`` replaces the
    environment when given, as in :func:`subprocess.run`. ``in_process``: ``None`` runs the command in this
    process when that is equivalent (see the module's docstring), ``False`` always in a child process.
    """
    argv = [str(a) for a in args]
    if in_process is None:
        in_process = os.environ.get("NDRQL_TEST_CHILD") != "1" and preexec_fn is None and is_console_script(exe) and env_is_runtime_only(env)
    if in_process:
        return run_main(argv, cwd=cwd, env=env, exe=exe)
    return run_script(exe, *argv, cwd=cwd, env=env, timeout=timeout, preexec_fn=preexec_fn)


def run_script(exe: Sequence[str], *args: object, cwd: str | Path | None = None, env: Mapping[str, str] | None = None,
               timeout: float = TIMEOUT,
               preexec_fn: Callable[[], None] | None = None) -> subprocess.CompletedProcess[str]:
    """Run ``exe ARGS`` in a child process (the real console script, end to end)."""
    return subprocess.run([*exe, *map(str, args)], capture_output=True, text=True, cwd=cwd, env=env,
                          timeout=timeout, preexec_fn=preexec_fn)


def is_console_script(exe: Sequence[str]) -> bool:
    """Whether ``exe`` is this environment's ``ndrql`` console script alone (what ``main()`` stands for)."""
    return len(exe) == 1 and Path(exe[0]).name == "ndrql" and Path(exe[0]).parent == Path(sys.executable).parent


def env_is_runtime_only(env: Mapping[str, str] | None) -> bool:
    """Whether ``env`` differs from this process's environment in ``NDRQL_*`` variables only."""
    if env is None:
        return True
    keys = set(env) | set(os.environ)
    return all(k.startswith(IN_PROCESS_ENV_PREFIX) for k in keys if env.get(k) != os.environ.get(k))


def run_main(argv: Sequence[str], *, cwd: str | Path | None = None, env: Mapping[str, str] | None = None,
             exe: Sequence[str] = ("ndrql",)) -> subprocess.CompletedProcess[str]:
    """``ndrql ARGV`` through ``ndrql.cli.main`` in this process, as the console script runs it.

    The exit code is ``main``'s return value or its ``SystemExit``; an exception that escapes ``main`` is
    printed as the interpreter would (traceback on stderr, exit code 1). Output is decoded as
    ``subprocess.run(text=True)`` decodes it (universal newlines).
    """
    from ndrql.cli import main

    out, err = _Stream(), _Stream()
    with _process_state(cwd, env), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(argv))
        except SystemExit as exc:
            code = _exit_code(exc.code, err)
        except Exception:  # the console script would die with the traceback
            traceback.print_exc()
            code = 1
    return subprocess.CompletedProcess([*exe, *argv], code, out.text(), err.text())


class _Stream(io.TextIOWrapper):
    """A text stream with a binary ``buffer``, as ``sys.stdout`` has (``fileno`` raises, as for a pipe-less stream)."""

    def __init__(self) -> None:
        super().__init__(io.BytesIO(), encoding="utf-8", errors="backslashreplace", write_through=True)

    def text(self) -> str:
        self.flush()
        raw = self.buffer.getvalue().decode("utf-8", errors="replace")  # type: ignore[attr-defined]
        return raw.replace("\r\n", "\n").replace("\r", "\n")


def _exit_code(code: object, err: io.TextIOBase) -> int:
    """What the interpreter makes of ``sys.exit(code)``."""
    if code is None:
        return 0
    if isinstance(code, int):
        return code & 0xFF
    print(code, file=err)
    return 1


@contextlib.contextmanager
def _process_state(cwd: str | Path | None, env: Mapping[str, str] | None) -> Iterator[None]:
    """A fresh process's view for one command: empty ndrql caches, ``cwd``, ``env``, the interpreter's default
    warning filters; afterwards this process's folder, environment, filters and random state as they were."""
    _clear_ndrql_caches()
    before_dir, before_env = os.getcwd(), dict(os.environ)
    before_format = warnings.formatwarning
    rng = _random_state()
    try:
        with warnings.catch_warnings():
            _default_warning_filters()
            if cwd is not None:
                os.chdir(cwd)
            if env is not None:
                os.environ.clear()
                os.environ.update(env)
            yield
    finally:
        os.chdir(before_dir)
        if dict(os.environ) != before_env:
            os.environ.clear()
            os.environ.update(before_env)
        warnings.formatwarning = before_format
        _set_random_state(rng)


def _clear_ndrql_caches() -> None:
    """Empty every ``lru_cache`` of ndrql's loaded modules (loaded models, presets, splits): a new process has none."""
    for name, module in list(sys.modules.items()):
        if module is None or not (name == "ndrql" or name.startswith("ndrql.")):
            continue
        for value in list(vars(module).values()):
            if callable(getattr(value, "cache_clear", None)) and getattr(value, "__module__", None) == name:
                value.cache_clear()


def _default_warning_filters() -> None:
    """The warning filters of a new interpreter (``python -W`` unset): pytest's ``error`` filter does not apply
    to a command, which shows a warning as a line on stderr."""
    warnings.resetwarnings()
    warnings.filterwarnings("default", category=DeprecationWarning, module="__main__")
    for category in (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning):
        warnings.filterwarnings("ignore", category=category, append=True)


def _random_state() -> tuple[object, ...]:
    import numpy as np

    torch = sys.modules.get("torch")
    saved = (torch.get_rng_state(), torch.get_num_threads()) if torch is not None else None
    return random.getstate(), np.random.get_state(), saved


def _set_random_state(state: tuple[object, ...]) -> None:
    import numpy as np

    py, nps, saved = state
    random.setstate(py)  # type: ignore[arg-type]
    np.random.set_state(nps)  # type: ignore[arg-type]
    torch = sys.modules.get("torch")
    if torch is not None and saved is not None:
        torch.set_rng_state(saved[0])  # type: ignore[index]
        if torch.get_num_threads() != saved[1]:  # type: ignore[index]
            torch.set_num_threads(saved[1])  # type: ignore[index]


def assert_one_line_error(r: subprocess.CompletedProcess[str], needle: str = "") -> str:
    """Assert exit code 2 and exactly one stderr line ``ndrql: error: ...`` that contains ``needle``; return it.

    One line rules out a traceback. Messages show at most the last 3,000 characters of stderr.
    """
    tail = r.stderr[-3000:]
    lines = r.stderr.splitlines()
    assert r.returncode == 2, f"exit {r.returncode}, stdout:\n{r.stdout[-3000:]}\nstderr:\n{tail}"
    assert len(lines) == 1 and r.stderr.endswith("\n"), f"not one line on stderr:\n{tail}"
    assert lines[0].startswith("ndrql: error: ") and needle in lines[0], lines[0][:600]
    return lines[0]
