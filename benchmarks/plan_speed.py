"""End-to-end speed of ``ndrql plan`` on a 201x201 map, and the start-up of the ``ndrql`` command.

    .venv/bin/python benchmarks/plan_speed.py               # prints figures (about a minute)
    .venv/bin/python benchmarks/plan_speed.py --check       # exit 1 if the work median exceeds 0.5 s
    .venv/bin/python benchmarks/plan_speed.py --repeat 9    # more runs per figure

What it measures (each figure the median of ``--repeat`` runs, wall and CPU):

1. start-up: ``ndrql --help`` (Python, the CLI and its parsers; no torch, no numba);
2. the real console script ``ndrql plan <bundled 201x201 map> --start 25,179 --goal 167,5 --json F``
   with NDR-QL (default) and with QL (no model): the whole command, and the stages it reports in its
   JSON: ``startup`` (numba kernel loaded from its disk cache), ``map``, ``load`` (weights; with the
   torch import on the torch backend), ``predict``, ``priors``, ``learn``; "work" = load + predict +
   priors + learn; NDR-QL once with ``--backend torch`` (the reference) and once with the default
   backend (ONNX Runtime when installed), in the same run;
3. the numba disk cache: one ``ndrql plan --method QL`` with a fresh empty ``NUMBA_CACHE_DIR``
   (compiles), then a second one with the same directory (loads), stage ``startup``;
4. the Python API in one process: ``ndrql.plan`` 10 times on the same map (model loaded once).

CPU time of the subprocesses comes from ``getrusage(RUSAGE_CHILDREN)``; in-process stages use
``time.process_time``. On a busy machine wall time is noisy; CPU time is the steadier figure.
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

BUDGET = 0.5  # seconds of work (load + predict + priors + learn), issue 6
START, GOAL = "25,179", "167,5"
EXE = str(Path(sys.executable).with_name("ndrql"))


def sample_map() -> str:
    from importlib import resources

    return str(resources.files("ndrql") / "data" / "sample_map.png")


def timed(cmd: list[str], env: dict | None = None) -> tuple[float, float, subprocess.CompletedProcess]:
    """Run ``cmd``; (wall s, CPU s of the child, completed process)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        sys.exit(f"command failed: {' '.join(cmd)}\n{r.stderr}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), r


def med(xs: list[float]) -> float:
    return statistics.median(xs)


def plan_runs(method: str, repeat: int, tmp: Path, backend: str = "auto") -> dict:
    walls, cpus, stages_w, stages_c = [], [], [], []
    # one untimed run first: fills the ONNX export cache, as a user's first plan does once per weights file
    timed([EXE, "plan", sample_map(), "--start", START, "--goal", GOAL, "--method", method, "--backend", backend])
    for i in range(repeat):
        out = tmp / f"{method}-{backend}-{i}.json"
        w, c, _ = timed([EXE, "plan", sample_map(), "--start", START, "--goal", GOAL, "--method", method,
                         "--backend", backend, "--json", str(out)])
        data = json.loads(out.read_text())
        walls.append(w)
        cpus.append(c)
        stages_w.append(data["timings"]["wall"])
        stages_c.append(data["timings"]["cpu"])
    names = list(stages_w[0])
    return {
        "command_wall": med(walls), "command_cpu": med(cpus),
        "stages_wall": {k: med([s[k] for s in stages_w]) for k in names},
        "stages_cpu": {k: med([s[k] for s in stages_c]) for k in names},
        "work_wall": med([sum(s[k] for k in ("load", "predict", "priors", "learn")) for s in stages_w]),
        "work_cpu": med([sum(s[k] for k in ("load", "predict", "priors", "learn")) for s in stages_c]),
        "steps": data["runs"][0]["convergence_steps"],
    }


def api_runs(n: int = 10) -> dict:
    import ndrql
    from ndrql.maps.bundled import bundled_sample

    s = bundled_sample()
    per = []
    for seed in range(n):
        rep = ndrql.solve(s.grid_map, s.start, s.goal, "NDR-QL", [seed], workers=1)
        per.append((rep.timings, rep.cpu_times))
    later = per[1:]
    return {
        "first_work_wall": sum(per[0][0][k] for k in ("load", "predict", "priors", "learn")),
        "first_startup_wall": per[0][0]["startup"],
        "later_work_wall": med([sum(t[k] for k in ("load", "predict", "priors", "learn")) for t, _ in later]),
        "later_work_cpu": med([sum(c[k] for k in ("load", "predict", "priors", "learn")) for _, c in later]),
        "later_load_wall": med([t["load"] for t, _ in later]),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="runs per figure (median reported; default 5)")
    ap.add_argument("--check", action="store_true", help=f"exit 1 if the median work exceeds {BUDGET} s CPU")
    args = ap.parse_args(argv)

    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").exists() else platform.processor()
    import numba
    import torch

    print(f"machine: {cpu}, {os.cpu_count()} logical cores, load average {os.getloadavg()[0]:.1f}; "
          f"Python {platform.python_version()}, torch {torch.__version__}, numba {numba.__version__}")
    from ndrql.model.predict import default_weights_path

    print(f"weights: {default_weights_path()}; median of {args.repeat} runs\n")

    helps = [timed([EXE, "--help"]) for _ in range(args.repeat)]
    print(f"start-up, `ndrql --help`: wall {med([h[0] for h in helps]):.3f} s, CPU {med([h[1] for h in helps]):.3f} s")

    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        # the reference (torch backend) and the default (ONNX Runtime when installed) in the same run
        results = {label: plan_runs(m, args.repeat, tmp, b) for label, m, b in
                   (("NDR-QL, --backend torch", "NDR-QL", "torch"), ("NDR-QL, default backend", "NDR-QL", "auto"),
                    ("QL", "QL", "auto"))}
        for m, r in results.items():
            sw, sc = r["stages_wall"], r["stages_cpu"]
            print(f"\n`ndrql plan` 201x201, {m} ({r['steps']:,} steps to convergence): whole command wall "
                  f"{r['command_wall']:.2f} s, CPU {r['command_cpu']:.2f} s")
            print("  stage      wall s   CPU s")
            for k in sw:
                print(f"  {k:<9} {sw[k]:7.3f} {sc[k]:7.3f}")
            print(f"  work      {r['work_wall']:7.3f} {r['work_cpu']:7.3f}   (load + predict + priors + learn)")

        cache = tmp / "numba-cache"
        env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
        cold_warm = []
        for label in ("empty cache (compiles)", "second run (loads)"):
            out = tmp / f"cache-{len(cold_warm)}.json"
            w, c, _ = timed([EXE, "plan", sample_map(), "--start", START, "--goal", GOAL, "--method", "QL",
                             "--json", str(out)], env=env)
            st = json.loads(out.read_text())["timings"]
            cold_warm.append((label, w, c, st["wall"]["startup"], st["cpu"]["startup"]))
        print("\nnumba disk cache (`ndrql plan --method QL`, fresh NUMBA_CACHE_DIR):")
        for label, w, c, sw_, sc_ in cold_warm:
            print(f"  {label:<24} command wall {w:5.2f} s CPU {c:5.2f} s; kernel load/compile wall {sw_:5.2f} s CPU {sc_:5.2f} s")

    api = api_runs()
    print(f"\nPython API, 10 x ndrql.solve(201x201, NDR-QL) in one process: first call start-up "
          f"{api['first_startup_wall']:.2f} s + work {api['first_work_wall']:.3f} s; later calls work "
          f"{api['later_work_wall']:.3f} s wall / {api['later_work_cpu']:.3f} s CPU (load {api['later_load_wall']:.4f} s: cached)")

    ref, new = results["NDR-QL, --backend torch"], results["NDR-QL, default backend"]
    print(f"\ndefault backend vs torch: whole command {new['command_wall']:.2f} s vs {ref['command_wall']:.2f} s wall "
          f"({ref['command_wall'] / new['command_wall']:.2f}x), {new['command_cpu']:.2f} s vs {ref['command_cpu']:.2f} s CPU "
          f"({ref['command_cpu'] / new['command_cpu']:.2f}x); work {new['work_cpu']:.3f} s vs {ref['work_cpu']:.3f} s CPU")
    work = new["work_cpu"]
    ok = work <= BUDGET
    print(f"\nbudget: work (load + predict + priors + learn) {work:.3f} s CPU <= {BUDGET} s: {'met' if ok else 'NOT met'}")
    return 0 if ok or not args.check else 1


if __name__ == "__main__":
    sys.exit(main())
