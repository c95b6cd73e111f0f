"""The one executor of ndrql (:func:`run_calls`) and its worker processes, which die with their parent.

:func:`run_calls` runs many independent calls of one function serially, on a local process pool,
on threads or on Ray, and hands back the results in call order whatever ran them and in whatever
order they finished: plan runs (:func:`ndrql.planning.runner.run_many`), sweeps
(:func:`ndrql.experiments.sweep.run_sweep`) and the training of Table 4's variants all use it.

The workers of an ordinary process pool outlive a parent that is killed with SIGKILL (``kill -9``,
the out-of-memory killer): they wait forever for work that never comes. Every pool in ndrql is made
by :func:`process_pool` (and every multiprocessing manager by :func:`start_manager`), whose worker
initializer :func:`die_with_parent`

- asks Linux to SIGKILL the worker the moment its parent dies (``prctl(PR_SET_PDEATHSIG)``), and
- on every platform starts a watchdog thread that ends the worker once its parent process is gone
  (its parent pid changes when the parent dies and the worker is re-parented).

``PR_SET_PDEATHSIG`` fires when the *thread* that started the worker ends, so create and use a pool
from one thread that outlives it (the calling thread, as every pool in ndrql does).

Layering: standard library and :mod:`ndrql.errors` only (Ray is imported by the ``ray`` executor
alone); any layer may use it.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from typing import TYPE_CHECKING, Any, Callable, Sequence

from ndrql.errors import NdrqlError

if TYPE_CHECKING:  # multiprocessing and concurrent.futures load when a pool starts (about 30 ms of start-up)
    from concurrent.futures import Executor, Future, ProcessPoolExecutor

__all__ = ["EXECUTORS", "die_with_parent", "pick_executor", "process_pool", "ray_available", "run_calls", "start_manager"]

#: Where :func:`run_calls` can run its calls.
EXECUTORS = ("serial", "process", "thread", "ray")

_PR_SET_PDEATHSIG = 1
WATCH_SECONDS = 0.5
"""How often the watchdog thread checks that the parent still runs."""


def _set_pdeathsig() -> bool:
    """Linux: SIGKILL this process when its parent dies; ``False`` where that is not available."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (ImportError, OSError, AttributeError):
        return False


def _watch(parent_pid: int, seconds: float) -> None:
    while True:
        time.sleep(seconds)
        if os.getppid() != parent_pid:
            os._exit(1)


def die_with_parent(parent_pid: int, seconds: float = WATCH_SECONDS) -> None:
    """Make this (worker) process end when the process ``parent_pid`` dies (module docstring)."""
    _set_pdeathsig()
    if os.getppid() != parent_pid:  # the parent died before the death signal was armed
        os._exit(1)
    threading.Thread(target=_watch, args=(parent_pid, seconds), name="ndrql-parent-watch", daemon=True).start()


def _init_worker(parent_pid: int, initializer: Callable[..., Any] | None, initargs: tuple) -> None:
    die_with_parent(parent_pid)
    if initializer is not None:
        initializer(*initargs)


def _context(start_method: str | None) -> Any:
    import multiprocessing

    if start_method == "fork" and "fork" not in multiprocessing.get_all_start_methods():
        start_method = None  # fork where possible (workers inherit loaded kernels), else the default
    return multiprocessing.get_context(start_method)


def process_pool(workers: int, *, start_method: str | None = None, initializer: Callable[..., Any] | None = None,
                 initargs: tuple = ()) -> ProcessPoolExecutor:
    """A ``ProcessPoolExecutor`` of ``workers`` processes that die with this process.

    ``start_method`` is ``"fork"`` (falls back to the platform default where there is no fork),
    ``"spawn"``, ``"forkserver"`` or ``None`` (the default). ``initializer(*initargs)`` runs in
    each worker after :func:`die_with_parent`.
    """
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    from concurrent.futures import ProcessPoolExecutor

    return ProcessPoolExecutor(max_workers=workers, mp_context=_context(start_method), initializer=_init_worker,
                               initargs=(os.getpid(), initializer, initargs))


def start_manager(start_method: str | None = None) -> Any:
    """A started ``multiprocessing`` ``SyncManager`` whose server process dies with this process.

    Use it as a context manager (``with start_manager("spawn") as manager: ...``).
    """
    from multiprocessing.managers import SyncManager

    manager = SyncManager(ctx=_context(start_method))
    manager.start(die_with_parent, (os.getpid(),))
    return manager


# ------------------------------------------------------------------------------------ executor


def pick_executor(executor: str, workers: int, calls: int) -> str:
    """``serial`` where a local pool does not pay (one worker, or at most one call), else ``executor``."""
    if executor in ("process", "thread") and (workers == 1 or calls <= 1):
        return "serial"
    return executor


def ray_available() -> bool:
    """Whether Ray is installed (the ``ray`` executor needs it)."""
    try:
        import ray  # noqa: F401
    except ImportError:
        return False
    return True


def run_calls(fn: Callable[..., Any], calls: Sequence[tuple], *, executor: str = "process", workers: int = 2,
              start_method: str | None = "fork", ray_address: str | None = None,
              on_result: Callable[[int, Any], None] | None = None, poll: Callable[[], None] | None = None,
              poll_seconds: float = 2.0) -> list[Any]:
    """``fn(*args)`` for every ``args`` of ``calls``; the results in call order, whatever the executor.

    ``executor``: ``serial`` (this process, in order), ``process`` (:func:`process_pool` of
    ``min(workers, len(calls))`` processes started by ``start_method``: ``fork`` where the platform
    has it, so workers inherit loaded kernels, or ``spawn`` for a clean start), ``thread`` (for
    functions that release the GIL) or ``ray`` (a task of one CPU per call, retried twice, on a local
    instance of ``workers`` CPUs or the cluster at ``ray_address``). ``fn`` and the arguments must
    pickle for ``process`` and ``ray``.

    ``on_result(i, result)`` runs in this process as call ``i`` finishes (completion order);
    ``poll()`` every ``poll_seconds`` while calls run and before each batch of finished ones is handed
    on. When a call raises, the calls not started yet are cancelled and the error is raised here.
    """
    if executor not in EXECUTORS:
        raise NdrqlError(f"unknown executor {executor!r}; valid: {', '.join(EXECUTORS)}")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    calls = list(calls)
    results: list[Any] = [None] * len(calls)

    def finish(i: int, result: Any) -> None:
        results[i] = result
        if on_result is not None:
            on_result(i, result)

    if executor == "serial":
        for i, args in enumerate(calls):
            finish(i, fn(*args))
            if poll is not None:
                poll()
    elif executor == "ray":
        _run_ray(fn, calls, workers, ray_address, finish, poll, poll_seconds)
    elif calls:
        from concurrent.futures import ThreadPoolExecutor

        n = min(workers, len(calls))
        pool: Executor = (ThreadPoolExecutor(max_workers=n) if executor == "thread"
                          else process_pool(n, start_method=start_method))
        with pool:
            _run_pool(pool, fn, calls, finish, poll, poll_seconds)
    return results


def _run_pool(pool: Executor, fn: Callable[..., Any], calls: list[tuple], finish: Callable[[int, Any], None],
              poll: Callable[[], None] | None, poll_seconds: float) -> None:
    from concurrent.futures import FIRST_COMPLETED, wait

    pending: dict[Future, int] = {pool.submit(fn, *args): i for i, args in enumerate(calls)}
    try:
        while pending:
            finished, _ = wait(pending, timeout=poll_seconds if poll is not None else None, return_when=FIRST_COMPLETED)
            if poll is not None:
                poll()
            for fut in finished:
                finish(pending.pop(fut), fut.result())
    except BaseException:
        for fut in pending:
            fut.cancel()
        raise


def _run_ray(fn: Callable[..., Any], calls: list[tuple], workers: int, address: str | None,
             finish: Callable[[int, Any], None], poll: Callable[[], None] | None, poll_seconds: float) -> None:
    try:
        import ray
    except ImportError:
        raise NdrqlError("--executor ray needs Ray: pip install 'ndrql[ray]' (or pip install ray)") from None
    started = False
    if not ray.is_initialized():
        kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False, "configure_logging": False}
        if address:
            ray.init(address=address, **kwargs)
        else:
            ray.init(num_cpus=workers, **kwargs)
        started = True
    try:
        remote = ray.remote(num_cpus=1, max_retries=2)(fn)
        pending = {remote.remote(*args): i for i, args in enumerate(calls)}
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=poll_seconds if poll is not None else None)
            if poll is not None:
                poll()
            for ref in ready:
                finish(pending.pop(ref), ray.get(ref))
    finally:
        if started:
            ray.shutdown()
