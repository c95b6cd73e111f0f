"""One child process that runs many ``ndrql`` commands through ``main()``: for commands that must not run in the
test process (a memory cap on the address space) but need not pay an interpreter and torch each.

:class:`CommandChild` starts ``python -m helpers.child`` under a ``preexec_fn`` (such as ``RLIMIT_AS``) and sends
it one command at a time; the child runs each as :func:`helpers.cli.run_main` does (ndrql's caches emptied, the
folder, environment and warning filters put back) and answers with the exit code, stdout and stderr. A command
that kills the child (a crash, the kernel's OOM killer) fails its test, and the next command starts a new child.
"""

from __future__ import annotations

import json
import os
import select
import subprocess
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from helpers import TESTS_DIR
from helpers.cli import TIMEOUT, env_is_runtime_only


class CommandChild:
    """A child process (started on first use, under ``preexec_fn``) that runs ``ndrql`` commands one by one."""

    def __init__(self, preexec_fn: Callable[[], None] | None = None) -> None:
        self._preexec_fn = preexec_fn
        self._proc: subprocess.Popen[str] | None = None

    def run(self, *args: object, cwd: str | Path | None = None, env: Mapping[str, str] | None = None,
            timeout: float = TIMEOUT) -> subprocess.CompletedProcess[str]:
        """``ndrql ARGS`` in the child; ``env`` may differ from this process's in ``NDRQL_*`` variables only."""
        assert env_is_runtime_only(env), "a child that runs many commands takes NDRQL_* variables only"
        argv = [str(a) for a in args]
        changed = {k: env.get(k) for k in set(env) | set(os.environ) if env.get(k) != os.environ.get(k)} if env else {}
        proc = self._start()
        assert proc.stdin is not None and proc.stdout is not None
        proc.stdin.write(json.dumps({"argv": argv, "cwd": None if cwd is None else str(cwd), "env": changed}) + "\n")
        proc.stdin.flush()
        ready, _, _ = select.select([proc.stdout], [], [], timeout)
        line = proc.stdout.readline() if ready else ""
        if not line:
            self.close()
            raise AssertionError(f"the command child died or hung on ndrql {' '.join(argv)[:300]}")
        code, out, err = json.loads(line)
        return subprocess.CompletedProcess(["ndrql", *argv], code, out, err)

    def close(self) -> None:
        """Stop the child (it ends when its input closes)."""
        proc, self._proc = self._proc, None
        if proc is not None:
            for stream in (proc.stdin, proc.stdout):
                if stream is not None:
                    stream.close()
            try:
                proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()

    def _start(self) -> subprocess.Popen[str]:
        if self._proc is None or self._proc.poll() is not None:
            env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(TESTS_DIR), os.environ.get("PYTHONPATH")]))}
            self._proc = subprocess.Popen([sys.executable, "-m", "helpers.child"], stdin=subprocess.PIPE,
                                          stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env,
                                          preexec_fn=self._preexec_fn)
        return self._proc


def serve(requests: Sequence[str] | None = None) -> None:
    """The child's loop: one JSON request a line on stdin, one JSON answer a line on the original stdout."""
    from helpers.cli import run_main

    answers = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)  # whatever a library writes to file descriptor 1 cannot break the answers
    for line in requests if requests is not None else sys.stdin:
        req = json.loads(line)
        env = dict(os.environ)
        for key, value in req["env"].items():  # the NDRQL_* variables the test set (a value) or removed (None)
            if value is None:
                env.pop(key, None)
            else:
                env[key] = value
        r = run_main(req["argv"], cwd=req["cwd"], env=env)
        answers.write(json.dumps([r.returncode, r.stdout, r.stderr]) + "\n")
        answers.flush()


if __name__ == "__main__":
    serve()
