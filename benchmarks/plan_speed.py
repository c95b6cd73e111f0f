"""The latency budget of ``ndrql plan`` on the bundled map, whole process and per stage, against ``ndrql astar``.

    .venv/bin/python benchmarks/plan_speed.py               # prints the figures (a few minutes on a busy machine)
    .venv/bin/python benchmarks/plan_speed.py --check       # exit 1 when a budget is not met
    .venv/bin/python benchmarks/plan_speed.py --repeat 9    # more runs per figure

What it measures, each figure the median of ``--repeat`` runs of the real console script (wall and
CPU of the whole process; CPU from ``getrusage(RUSAGE_CHILDREN)``), all in the same run:

1. the references: ``ndrql --help`` (Python and the CLI) and ``ndrql astar --example`` (the same map,
   A* on the planning grid: what a user compares a planner with);
2. warm ``ndrql plan --example --json F`` (NDR-QL, the defaults), with the stages the command reports
   in its JSON (``grid``: inflation, the size search and the planning grid, which loads the compiled
   kernels; ``load``: the model; ``predict``; ``priors``; ``learn``; ``route``) and the final path's
   length over the map's own shortest route; the same with ``--symmetries 4`` for the cost of averaging
   the prediction over four orientations;
3. the first run after an install: ``ndrql plan --example`` with an empty ``NUMBA_CACHE_DIR`` and an empty
   ``NDRQL_CACHE`` (where the first run keeps ONNX Runtime's optimised graph), and a second run with the
   same folders. With the C kernels built at install time (``ndrql.maps._kernels``) nothing
   compiles: neither run may say it compiles, and the cache folder stays empty. With numba's kernels
   (``NDRQL_KERNELS=numba``, or no extension) the first run compiles them and says so in one line, the
   second loads them and says nothing; ``--numba-first-run`` measures that fallback too.

Which kernels ran (``c`` or ``numba``, from ``plan --json``) is printed beside the figures. The runs use
Python's bytecode cache (``__pycache__``) as an installed package does: ``PYTHONDONTWRITEBYTECODE`` is
cleared for them, since with it set every run compiles ndrql's modules from source again (about 0.2 s);
``--bytecode env`` keeps the environment as it is.

Budgets (issue "the first ten minutes"): warm ``plan`` <= :data:`WARM_BUDGET` s wall with a final path
at most :data:`PATH_BUDGET` x the map's shortest route; first run <= :data:`COLD_BUDGET` s wall. On a
machine shared with other jobs wall times grow with the load; the ratio to ``ndrql astar`` measured
in the same run is the steadier figure, and the load average is printed before and after.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

WARM_BUDGET = 0.8  # s wall, warm `ndrql plan` on the bundled map
COLD_BUDGET = 4.0  # s wall, the first `ndrql plan` after an install
PATH_BUDGET = 1.10  # final path / the map's own shortest route
EXE = str(Path(sys.executable).with_name("ndrql"))
STAGES = ("grid", "load", "predict", "priors", "learn", "route")


def timed(cmd: list[str], env: dict | None = None) -> tuple[float, float, subprocess.CompletedProcess]:
    """Run ``cmd``; (wall s, CPU s of the child, completed process). Exits on failure."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tempfile.gettempdir())
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        sys.exit(f"command failed: {' '.join(cmd)}\n{r.stderr}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), r


def med(xs: list[float]) -> float:
    return statistics.median(xs)


def command_runs(cmd: list[str], repeat: int) -> dict:
    """Median wall and CPU of ``cmd`` over ``repeat`` runs (one untimed run first)."""
    timed(cmd)
    runs = [timed(cmd) for _ in range(repeat)]
    return {"wall": med([r[0] for r in runs]), "cpu": med([r[1] for r in runs])}


def plan_runs(extra: list[str], repeat: int, tmp: Path) -> dict:
    """Warm ``ndrql plan --example``: whole command, stages and the final path (medians)."""
    base = [EXE, "plan", "--example", *extra]
    timed(base)  # fills the ONNX Runtime and numba caches, as a user's first plan does once
    walls, cpus, st_w, st_c, ratio = [], [], [], [], []
    for i in range(repeat):
        out = tmp / f"plan-{i}.json"
        w, c, _ = timed([*base, "--json", str(out)])
        data = json.loads(out.read_text())
        walls.append(w)
        cpus.append(c)
        st_w.append(data["timings"]["wall"])
        st_c.append(data["timings"]["cpu"])
        run = data["runs"][0]
        ratio.append(run["route"]["length_px"]["final"] / data["planning_grid"]["auto"]["full_length_px"])
    return {"wall": med(walls), "cpu": med(cpus), "path_ratio": med(ratio), "method": run["method"],
            "kernels": data.get("kernels", "numba"),
            "size": data["planning_grid"]["size"], "threshold": data["prediction_quality"]["threshold"],
            "stages_wall": {k: med([s.get(k, 0.0) for s in st_w]) for k in STAGES},
            "stages_cpu": {k: med([s.get(k, 0.0) for s in st_c]) for k in STAGES}}


def first_runs(tmp: Path, kernels: str | None = None) -> list[dict]:
    """``ndrql plan --example`` with an empty numba cache folder and an empty ``$NDRQL_CACHE`` (so the first run
    also makes ONNX Runtime's optimised graph), then again with the same folders;
    ``kernels`` sets ``NDRQL_KERNELS`` (None: as the environment has it)."""
    cache = tmp / f"numba-cache-{kernels or 'default'}"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "NDRQL_CACHE": str(tmp / f"ndrql-cache-{kernels or 'default'}")}
    if kernels:
        env["NDRQL_KERNELS"] = kernels
    out = []
    for label in ("first run", "second run"):
        w, c, r = timed([EXE, "plan", "--example"], env=env)
        notice = [line for line in r.stderr.splitlines() if "compiling" in line]
        cached = sum(1 for p in cache.rglob("*") if p.is_file()) if cache.exists() else 0
        out.append({"label": label, "wall": w, "cpu": c, "notice": notice, "cache_files": cached})
    return out


def print_first(title: str, runs: list[dict]) -> None:
    print(f"\n{title}:")
    for f in runs:
        said = f"says: {f['notice'][0][:90]}..." if f["notice"] else "says nothing"
        print(f"  {f['label']:<11} wall {f['wall']:5.2f} s, CPU {f['cpu']:5.2f} s; {len(f['notice'])} notice line(s); "
              f"{said}; numba cache files {f['cache_files']}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="runs per figure (median reported; default 5)")
    ap.add_argument("--check", action="store_true", help="exit 1 when a budget is not met")
    ap.add_argument("--bytecode", choices=("on", "env"), default="on",
                    help="on: the runs keep compiled modules in __pycache__ as an install does (default); env: as "
                         "PYTHONDONTWRITEBYTECODE says")
    ap.add_argument("--numba-first-run", action="store_true",
                    help="also the first run with numba's kernels (NDRQL_KERNELS=numba: they compile, 10-20 s)")
    args = ap.parse_args(argv)

    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").exists() else platform.processor()
    import numba
    import onnxruntime

    if args.bytecode == "on":
        os.environ.pop("PYTHONDONTWRITEBYTECODE", None)  # the child runs inherit it
    bytecode = "off (PYTHONDONTWRITEBYTECODE)" if os.environ.get("PYTHONDONTWRITEBYTECODE") else "on"
    load0 = os.getloadavg()[0]
    print(f"machine: {cpu}, {os.cpu_count()} logical cores, load average {load0:.1f}; Python "
          f"{platform.python_version()}, numba {numba.__version__}, onnxruntime {onnxruntime.__version__}; "
          f"median of {args.repeat} runs; bytecode cache {bytecode}\n")
    help_ = command_runs([EXE, "--help"], args.repeat)
    astar = command_runs([EXE, "astar", "--example"], args.repeat)
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        plan = plan_runs([], args.repeat, tmp)
        plan4 = plan_runs(["--symmetries", "4"], args.repeat, tmp)
        first = first_runs(tmp)
        fallback = first_runs(tmp, "numba") if args.numba_first_run else None
    load1 = os.getloadavg()[0]

    print(f"{'command':<44} {'wall s':>7} {'CPU s':>7} {'wall / astar':>12}")
    for name, r in (("ndrql --help", help_), ("ndrql astar --example (reference)", astar),
                    ("ndrql plan --example (defaults)", plan), ("ndrql plan --example --symmetries 4", plan4)):
        print(f"{name:<44} {r['wall']:7.2f} {r['cpu']:7.2f} {r['wall'] / astar['wall']:11.2f}x")
    for name, r in (("defaults", plan), ("--symmetries 4", plan4)):
        print(f"\nplan, {name}: {r['method']} on the {r['size']}-cell grid (Eq. 7 threshold {r['threshold']}), final "
              f"path {r['path_ratio']:.3f} x the map's shortest route")
        print("  stage      wall s   CPU s")
        for k in STAGES:
            print(f"  {k:<9} {r['stages_wall'][k]:7.3f} {r['stages_cpu'][k]:7.3f}")
        rest = r["wall"] - sum(r["stages_wall"].values())
        print(f"  {'rest':<9} {rest:7.3f}          (Python, imports, reading the map, the report)")
    print(f"\nkernels that ran: {plan['kernels']} (NDRQL_KERNELS={os.environ.get('NDRQL_KERNELS', 'auto')})")
    print_first(f"first run after an install (empty NUMBA_CACHE_DIR), {plan['kernels']} kernels", first)
    if fallback:
        print_first("first run after an install, numba's kernels (NDRQL_KERNELS=numba: the fallback)", fallback)
    print(f"\nload average {load0:.1f} before, {load1:.1f} after (2 cores: above 2, every figure includes waiting)")

    checks = [("warm plan wall", plan["wall"], WARM_BUDGET), ("final path / shortest", plan["path_ratio"], PATH_BUDGET),
              ("first run wall", first[0]["wall"], COLD_BUDGET)]
    ok = True
    for name, value, budget in checks:
        met = value <= budget
        ok &= met
        print(f"budget: {name} {value:.2f} <= {budget}: {'met' if met else 'NOT met'}")
    if plan["kernels"] == "c":
        once = not first[0]["notice"] and not first[1]["notice"] and first[1]["cache_files"] == 0
        print(f"C kernels: nothing compiles, no run says it does, numba's cache stays empty: {'yes' if once else 'NO'}")
    else:
        once = len(first[0]["notice"]) == 1 and not first[1]["notice"]
        print(f"the first run says it compiles in one line, later runs say nothing: {'yes' if once else 'NO'}")
    return 0 if (ok and once) or not args.check else 1


if __name__ == "__main__":
    sys.exit(main())
