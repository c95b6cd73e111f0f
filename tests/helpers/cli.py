"""Running the real ``ndrql`` console script, and the check every bad input gets (exit 2, one line)."""

from __future__ import annotations

import subprocess
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

#: Seconds before a hung command fails its test (commands are slow on a loaded machine; no timing is asserted).
TIMEOUT = 600.0


def run_cli(exe: Sequence[str], *args: object, cwd: str | Path | None = None, env: Mapping[str, str] | None = None,
            timeout: float = TIMEOUT, preexec_fn: Callable[[], None] | None = None) -> subprocess.CompletedProcess[str]:
    """Run ``exe ARGS`` (each argument through ``str``), capturing stdout and stderr as text.

    ``exe`` is the ``ndrql_exe`` fixture (the console script of this environment); ``env`` replaces the
    environment when given, as in :func:`subprocess.run`.
    """
    return subprocess.run([*exe, *map(str, args)], capture_output=True, text=True, cwd=cwd, env=env,
                          timeout=timeout, preexec_fn=preexec_fn)


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
