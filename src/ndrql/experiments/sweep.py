"""Resumable sweeps: many independent tasks, one atomic JSON file per finished task.

A :class:`Task` is a top-level (picklable) function, its arguments, a unique ``key`` and a
``fingerprint`` of everything that determines its result (:func:`ndrql.experiments.digests.fingerprint`).
:func:`run_sweep` first reads the task files already in ``out_dir`` and reuses every one whose
fingerprint matches; it runs the others on an executor and writes each result the moment it arrives (:func:`ndrql.io.write_json`), so a
sweep killed at any point resumes without redoing finished work. Results come back keyed by task,
so whatever ran them, and in whatever order they finished, the tables built from them are the same.

Executors (:func:`ndrql.workers.run_calls`, the one executor): ``serial`` (this process),
``process`` (a local process pool, forked where possible so workers inherit compiled kernels, whose
workers die with their parent; the default; one worker or one task runs in this process) and
``ray`` (``pip install ndrql[ray]``; a local Ray instance, or an existing cluster given by ``ray_address``).
"""

from __future__ import annotations

import json
import os
import socket
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

from tqdm import tqdm

from ndrql.errors import NdrqlError
from ndrql.io import make_folder, write_json
from ndrql.workers import pick_executor, run_calls

#: Valid executor names for :func:`run_sweep`.
EXECUTORS = ("process", "serial", "ray")


@dataclass(frozen=True)
class Task:
    """One unit of a sweep: ``fn(*args)`` must return a JSON-serialisable value."""

    key: str
    """Unique name in the sweep; also the file name (``<key>.json``), so only ``[A-Za-z0-9._+-]``."""
    fn: Callable[..., Any]
    """A module-level function (it is pickled to run in other processes)."""
    args: tuple = ()
    """Arguments of ``fn`` (picklable)."""
    fingerprint: str = ""
    """Digest of everything that determines the result; a stored file with another one is recomputed."""


@dataclass
class SweepReport:
    """What :func:`run_sweep` did."""

    results: dict[str, Any]
    """Result of every task, by key (reused and computed alike)."""
    computed: list[str] = field(default_factory=list)
    """Keys computed by this call, in the order they finished."""
    reused: list[str] = field(default_factory=list)
    """Keys read back from files written before."""
    seconds: float = 0.0
    """Wall time of the call."""


def _check_key(key: str) -> None:
    if not key or not all(ch.isalnum() or ch in "._+-" for ch in key):
        raise ValueError(f"task key {key!r} must be non-empty and use only letters, digits and . _ + -")


def task_path(out_dir: str | Path, key: str) -> Path:
    return Path(out_dir) / f"{key}.json"


def read_task(out_dir: str | Path, task: Task) -> dict | None:
    """The stored record of ``task`` if there is one with the same fingerprint, else ``None``."""
    path = task_path(out_dir, task.key)
    try:
        with open(path) as fh:
            rec = json.load(fh)
    except (FileNotFoundError, json.JSONDecodeError, UnicodeDecodeError):
        return None
    if not isinstance(rec, dict) or rec.get("key") != task.key or rec.get("fingerprint") != task.fingerprint:
        return None
    return rec


def _call(fn: Callable[..., Any], args: tuple) -> tuple[Any, dict]:
    t0 = time.perf_counter()
    out = fn(*args)
    return out, {"pid": os.getpid(), "host": socket.gethostname(), "seconds": time.perf_counter() - t0}


def _progress(total: int, initial: int, desc: str, enabled: bool) -> tqdm:
    return tqdm(total=total, initial=initial, desc=desc, unit="task", disable=not enabled, file=sys.stderr,
                dynamic_ncols=True, smoothing=0.1)


def run_sweep(
    tasks: Iterable[Task],
    out_dir: str | Path,
    executor: str = "process",
    workers: int = 2,
    progress: bool = True,
    desc: str = "sweep",
    ray_address: str | None = None,
) -> SweepReport:
    """Run ``tasks`` not already stored in ``out_dir``; store each result as it finishes (module doc)."""
    t0 = time.perf_counter()
    tasks = list(tasks)
    if executor not in EXECUTORS:
        raise NdrqlError(f"unknown executor {executor!r}; valid: {', '.join(EXECUTORS)}")
    if workers < 1:
        raise NdrqlError(f"workers must be >= 1, got {workers}")
    seen: set[str] = set()
    for t in tasks:
        _check_key(t.key)
        if t.key in seen:
            raise ValueError(f"duplicate task key {t.key!r}")
        seen.add(t.key)
    out_dir = make_folder(out_dir)
    report = SweepReport(results={})
    todo: list[Task] = []
    for t in tasks:
        rec = read_task(out_dir, t)
        if rec is None:
            todo.append(t)
        else:
            report.results[t.key] = rec["result"]
            report.reused.append(t.key)
    bar = _progress(len(tasks), len(report.reused), desc, progress)

    def done(task: Task, result: Any, meta: dict) -> None:
        meta["finished_at"] = time.time()
        # strict=False: a NaN in a result reads back as NaN, so a resumed sweep gives the same tables
        write_json(task_path(out_dir, task.key),
                   {"key": task.key, "fingerprint": task.fingerprint, "result": result, "meta": meta},
                   indent=None, strict=False)
        report.results[task.key] = result
        report.computed.append(task.key)
        bar.update(1)

    try:
        run_calls(_call, [(t.fn, t.args) for t in todo], executor=pick_executor(executor, workers, len(todo)),
                  workers=workers, ray_address=ray_address, on_result=lambda i, out: done(todo[i], *out))
    finally:
        bar.close()
    # Key order of the input, whatever the completion order.
    report.results = {t.key: report.results[t.key] for t in tasks}
    report.seconds = time.perf_counter() - t0
    return report
