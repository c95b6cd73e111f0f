"""Worker processes that die with their parent: the one way ndrql starts a process pool.

The workers of an ordinary process pool outlive a parent that is killed with SIGKILL (``kill -9``,
the out-of-memory killer): they wait forever for work that never comes. Every pool in ndrql is made
by :func:`process_pool` (and every multiprocessing manager by :func:`start_manager`), whose worker
initializer :func:`die_with_parent`

- asks Linux to SIGKILL the worker the moment its parent dies (``prctl(PR_SET_PDEATHSIG)``), and
- on every platform starts a watchdog thread that ends the worker once its parent process is gone
  (its parent pid changes when the parent dies and the worker is re-parented).

``PR_SET_PDEATHSIG`` fires when the *thread* that started the worker ends, so create and use a pool
from one thread that outlives it (the calling thread, as every pool in ndrql does).

Layering: standard library only; any layer may use it.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any, Callable

__all__ = ["die_with_parent", "process_pool", "start_manager"]

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
