"""Sweeps: resume after a real kill, executor equivalence, atomic task files."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from ndrql.experiments.digests import fingerprint
from ndrql.experiments.planning_runs import SweepOptions, make_tasks, summarize_runs
from ndrql.maps.problem import MapProblem
from ndrql.pipeline.samples import Problem
from ndrql.experiments.sweep import Task, read_task, run_sweep, task_path
from ndrql.planning.methods import Method, get_method

from helpers import TESTS_DIR
from helpers.sweep_tasks import slow_tasks


def _square(x: int) -> dict:
    return {"x": x, "y": x * x}


def _problems(n: int = 3) -> list[Problem]:
    """Small synthetic planning problems (a wall with a gap), no dataset or model needed."""
    out = []
    for k in range(n):
        b = np.zeros((16, 16), bool)
        b[8, : 10 + k] = True
        out.append(Problem("synthetic", k, "wall", MapProblem(np.zeros((16, 16), bool), (0, 0), (15, 15)), b, (0, 0), (15, 15), 30))
    return out


def _table(results: dict) -> dict:
    """What a table is built from (wall times excluded)."""
    out = {}
    for key, res in results.items():
        s = summarize_runs(res["runs"])
        s.pop("wall_time")
        out[key] = (s, [{k: v for k, v in r.items() if k != "wall_time"} for r in res["runs"]])
    return out


def test_serial_sweep_writes_one_file_per_task_and_reuses(tmp_path):
    tasks = [Task(f"t{i}", _square, (i,), fingerprint(i)) for i in range(5)]
    rep = run_sweep(tasks, tmp_path, executor="serial", progress=False)
    assert rep.computed == [f"t{i}" for i in range(5)] and rep.reused == []
    assert rep.results["t3"] == {"x": 3, "y": 9}
    assert sorted(p.name for p in tmp_path.glob("*.json")) == [f"t{i}.json" for i in range(5)]
    assert not list(tmp_path.glob(".*tmp"))  # no temporary file left behind
    rep2 = run_sweep(tasks, tmp_path, executor="process", progress=False)
    assert rep2.computed == [] and len(rep2.reused) == 5 and rep2.results == rep.results


def test_changed_fingerprint_or_corrupt_file_is_recomputed(tmp_path):
    tasks = [Task(f"t{i}", _square, (i,), fingerprint(i)) for i in range(3)]
    run_sweep(tasks, tmp_path, executor="serial", progress=False)
    task_path(tmp_path, "t0").write_text('{"key": "t0", "fingerp')  # torn write
    changed = [Task("t1", _square, (1,), fingerprint("other"))] + tasks[::2]
    rep = run_sweep(changed, tmp_path, executor="serial", progress=False)
    assert sorted(rep.computed) == ["t0", "t1"] and rep.reused == ["t2"]
    assert read_task(tmp_path, changed[0])["fingerprint"] == fingerprint("other")


def test_bad_keys_and_executor(tmp_path):
    from ndrql.errors import NdrqlError

    with pytest.raises(ValueError, match="letters"):
        run_sweep([Task("a/b", _square, (1,))], tmp_path, progress=False)
    with pytest.raises(ValueError, match="duplicate"):
        run_sweep([Task("a", _square, (1,)), Task("a", _square, (2,))], tmp_path, progress=False)
    with pytest.raises(NdrqlError, match="valid: process, serial, ray"):
        run_sweep([], tmp_path, executor="dask", progress=False)


def _planning_tasks(seeds: int = 3):
    opts = SweepOptions(seeds=seeds, progress=False)
    variants = [get_method("QL"), get_method("IQL"), Method("D-C", d_crf=True)]
    return make_tasks(_problems(), variants, opts, None, records=False)


def test_executor_equivalence_serial_process(tmp_path):
    tasks = _planning_tasks()
    a = run_sweep(tasks, tmp_path / "serial", executor="serial", progress=False)
    b = run_sweep(tasks, tmp_path / "process", executor="process", workers=2, progress=False)
    assert list(a.results) == list(b.results) == [t.key for t in tasks]
    assert _table(a.results) == _table(b.results)


@pytest.mark.slow
def test_executor_equivalence_ray(tmp_path):
    pytest.importorskip("ray")
    tasks = _planning_tasks()
    a = run_sweep(tasks, tmp_path / "serial", executor="serial", progress=False)
    b = run_sweep(tasks, tmp_path / "ray", executor="ray", workers=2, progress=False)
    assert sorted(b.computed) == sorted(t.key for t in tasks)
    assert _table(a.results) == _table(b.results)


_KILL_SCRIPT = textwrap.dedent(
    """
    import sys
    from ndrql.experiments.sweep import run_sweep
    sys.path.insert(0, {here!r})
    from helpers.sweep_tasks import slow_tasks
    run_sweep(slow_tasks(), sys.argv[1], executor="process", workers=2, progress=False)
    """
)


@pytest.mark.slow
def test_resume_after_kill(tmp_path):
    """Kill a running sweep (SIGKILL to its process group), resume: finished tasks are not redone,
    and the final table equals an uninterrupted run's."""
    out = tmp_path / "killed"
    script = tmp_path / "sweep.py"
    script.write_text(_KILL_SCRIPT.format(here=str(TESTS_DIR)))
    proc = subprocess.Popen([sys.executable, str(script), str(out)], start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    total = len(slow_tasks())
    deadline = time.time() + 120
    try:
        while time.time() < deadline:
            n = len(list(out.glob("*.json"))) if out.is_dir() else 0
            if n >= 6 or proc.poll() is not None:
                break
            time.sleep(0.05)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    with proc.stderr:  # read only when the assertion fails
        assert proc.returncode == -signal.SIGKILL, f"sweep was not killed midway: {proc.stderr.read().decode()[-500:]}"
    before = {p.name: (p.stat().st_mtime_ns, json.loads(p.read_text())) for p in out.glob("*.json")}
    assert 0 < len(before) < total, "kill did not land midway"
    tasks = slow_tasks()
    rep = run_sweep(tasks, out, executor="process", workers=2, progress=False)
    assert sorted(rep.reused) == sorted(n[:-5] for n in before)
    assert not set(rep.computed) & set(rep.reused) and len(rep.computed) + len(rep.reused) == total
    for name, (mtime, rec) in before.items():  # finished work untouched
        p = out / name
        assert p.stat().st_mtime_ns == mtime and json.loads(p.read_text()) == rec
    fresh = run_sweep(tasks, tmp_path / "fresh", executor="serial", progress=False)
    assert _table(rep.results) == _table(fresh.results)
