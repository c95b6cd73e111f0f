"""Worker processes die with their parent (ndrql.workers): a parent killed with SIGKILL leaves no orphans.

Each test starts a parent in a subprocess, waits until its pool workers run, kills the parent with
SIGKILL and checks that every worker is gone (a zombie waiting for init counts as gone).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from helpers import TESTS_DIR

pytestmark = pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs /proc (Linux)")



def _children(pid: int) -> set[int]:
    out = set()
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            status = Path(f"/proc/{entry}/status").read_text()
        except OSError:
            continue
        if f"\nPPid:\t{pid}\n" in status:
            out.add(int(entry))
    return out


def _alive(pid: int) -> bool:
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    return "\nState:\tZ" not in status


def _kill_parent_and_check(code: str, workers: int, tmp_path: Path, wait: float = 20) -> None:
    python_path = os.pathsep.join(filter(None, [str(TESTS_DIR), os.environ.get("PYTHONPATH")]))  # helpers, same ndrql
    proc = subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], cwd=tmp_path,
                            env={**os.environ, "NDRQL_CACHE": str(tmp_path / "cache"), "PYTHONPATH": python_path},
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        kids: set[int] = set()
        while time.monotonic() < deadline and len(kids) < workers:
            assert proc.poll() is None, proc.stderr.read().decode()[-2000:]
            kids = {k for k in _children(proc.pid) if _alive(k)}
            time.sleep(0.2)
        assert len(kids) >= workers, f"workers did not start: {kids}"
        time.sleep(1.0)  # let the workers pick up their (sleeping) tasks
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
        deadline = time.monotonic() + wait
        while time.monotonic() < deadline and any(_alive(k) for k in kids):
            time.sleep(0.2)
        left = [k for k in kids if _alive(k)]
        for k in left:  # clean up before failing
            os.kill(k, signal.SIGKILL)
        assert not left, f"orphaned workers still running: {left}"
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        proc.stderr.close()


POOL = """
import time
from ndrql.workers import process_pool
{patch}
with process_pool(2, start_method="{method}") as pool:
    futures = [pool.submit(time.sleep, 300) for _ in range(2)]
    time.sleep(300)
"""


@pytest.mark.parametrize("method", ["fork", "spawn"])
def test_pool_workers_die_with_their_parent(tmp_path, method):
    _kill_parent_and_check(POOL.format(method=method, patch=""), 2, tmp_path)


def test_without_the_initializer_workers_are_orphaned(tmp_path):
    """The check has teeth: with die_with_parent disabled, the same kill leaves the workers running."""
    patch = "import ndrql.workers as w\nw.die_with_parent = lambda *a, **k: None"
    with pytest.raises(AssertionError, match="orphaned workers still running"):
        _kill_parent_and_check(POOL.format(method="fork", patch=patch), 2, tmp_path, wait=3)


def test_watchdog_alone_ends_orphans(tmp_path):
    """Without PR_SET_PDEATHSIG (other platforms) the parent-pid watchdog still ends the workers."""
    patch = "import ndrql.workers as w\nw._set_pdeathsig = lambda: False"
    _kill_parent_and_check(POOL.format(method="fork", patch=patch), 2, tmp_path)


def test_sweep_workers_die_with_their_parent(tmp_path):
    """The pool behind ``ndrql reproduce`` (experiments.sweep.run_sweep, executor 'process')."""
    code = """
    import time
    from ndrql.experiments.sweep import Task, run_sweep
    tasks = [Task(key=f"t{i}", fn=time.sleep, args=(300 + i,)) for i in range(4)]
    run_sweep(tasks, "sweep", executor="process", workers=2, progress=False)
    """
    _kill_parent_and_check(code, 2, tmp_path)


def test_dataset_decode_workers_die_with_their_parent(tmp_path):
    """The pool that decodes the dataset into its cache (dataset.cache.build_split)."""
    code = """
    import time
    import ndrql.dataset.cache as cache
    from helpers.synthetic_dataset import make_tiny_dataset

    def slow_decode(args):
        time.sleep(300)

    root = make_tiny_dataset(__import__("pathlib").Path("ds"), n_train=4, n_test=2)
    cache._decode_map = slow_decode
    cache.build_split(root, "seen", workers=2, progress=False)
    """
    _kill_parent_and_check(code, 2, tmp_path)


def _set_env(key: str, value: str) -> None:
    os.environ[key] = value


def test_pool_results_are_unchanged(tmp_path):
    """The initializer changes nothing else: results come back in order, a user initializer runs."""
    from ndrql.workers import process_pool

    with process_pool(2, start_method="fork", initializer=_set_env, initargs=("NDRQL_T", "1")) as pool:
        assert list(pool.map(abs, [-1, -2, 3])) == [1, 2, 3]
        assert pool.submit(os.getenv, "NDRQL_T").result() == "1"
    with pytest.raises(ValueError, match="workers must be >= 1"):
        process_pool(0)


def _slow_square(x: int) -> int:
    time.sleep(0.05 * (3 - x % 4))  # later calls tend to finish first
    return x * x


def _fail_on_two(x: int) -> int:
    if x == 2:
        raise ZeroDivisionError("two")
    return x


@pytest.mark.parametrize("executor", ["serial", "process", "thread"])
def test_run_calls_returns_results_in_call_order(executor):
    """The one executor: results by call index whatever finished first; on_result once per call."""
    from ndrql.workers import run_calls

    seen, polls = [], []
    out = run_calls(_slow_square, [(i,) for i in range(8)], executor=executor, workers=2,
                    on_result=lambda i, r: seen.append((i, r)), poll=lambda: polls.append(1), poll_seconds=0.01)
    assert out == [i * i for i in range(8)]
    assert sorted(seen) == [(i, i * i) for i in range(8)] and polls
    with pytest.raises(ZeroDivisionError, match="two"):
        run_calls(_fail_on_two, [(i,) for i in range(4)], executor=executor, workers=2)


def test_run_calls_rejects_bad_input():
    from ndrql.errors import NdrqlError
    from ndrql.workers import pick_executor, run_calls

    with pytest.raises(NdrqlError, match="valid: serial, process, thread, ray"):
        run_calls(abs, [(1,)], executor="dask")
    with pytest.raises(ValueError, match="workers must be >= 1"):
        run_calls(abs, [(1,)], workers=0)
    assert [pick_executor("process", 1, 5), pick_executor("thread", 2, 1), pick_executor("process", 2, 2),
            pick_executor("ray", 1, 1)] == ["serial", "serial", "process", "ray"]
