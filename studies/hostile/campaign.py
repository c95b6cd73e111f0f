"""A hostile user's campaign against ndrql: flags, files, environment variables and API calls, each case run
in its own process under a 2 GB address-space cap, every file of its folder and of the installed package
hashed before and after. Counts per class (docs/reliability.md):

- data loss: a file that was there before changed or vanished;
- memory: the process's peak resident memory above 1.5 GB;
- traceback: a Python traceback on stderr;
- raw exception: the API raised something other than an ``NdrqlError``;
- wrong-silent: exit code 0 where the case must be refused (or a refusal where it must succeed);
- misleading: a refusal that does not name what to change (the case's needle);
- unclean line: a refusal that is not one ``ndrql: error:`` line with exit code 2, or raw control characters;
- hang: no exit within the time limit.

    .venv/bin/python studies/hostile/campaign.py [--only FAMILY] [--json OUT]   # one worker, about 12 minutes

The cases are generated (:mod:`studies.hostile.cases`); a case is a dict: ``argv`` (ndrql's arguments) or
``api`` (a Python call on ``ndrql``), ``expect`` (``refuse``, ``ok`` or ``any``), ``needle``, ``env``, ``setup``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from cases import all_cases, plant  # noqa: E402

ROOT = HERE.parents[1]
NDRQL = ROOT / ".venv" / "bin" / "ndrql"
PYTHON = ROOT / ".venv" / "bin" / "python"
CAP = 2_000_000_000
"""Address-space cap of every case (bytes)."""
MEMORY_LIMIT_KB = 1_500_000
TIME_LIMIT = 150.0
CLASSES = ("data loss", "memory", "traceback", "raw exception", "wrong-silent", "misleading", "unclean line", "hang")
API_RUNNER = """
import json, sys, warnings
warnings.simplefilter("ignore")
import ndrql
from ndrql.errors import NdrqlError
try:
    {call}
    print(json.dumps({{"raised": None}}))
except NdrqlError as exc:
    print(json.dumps({{"raised": "NdrqlError", "message": str(exc)[:300]}}))
except BaseException as exc:
    print(json.dumps({{"raised": type(exc).__name__, "message": str(exc)[:300]}}))
"""


def _digests(*folders: Path) -> dict[str, str]:
    out = {}
    for folder in folders:
        for p in sorted(folder.rglob("*")):
            if "__pycache__" in p.parts or ".cache" in p.parts or (folder.name == "ndrql" and p.suffix == ".py"):
                continue  # the package's code is edited by others while the campaign runs; its data files count
            if p.is_symlink():
                out[str(p)] = "-> " + os.readlink(p)
            elif p.is_file():
                try:
                    out[str(p)] = hashlib.sha256(p.read_bytes()).hexdigest()
                except OSError:
                    out[str(p)] = "unreadable"
    return out


def _cap() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (CAP, CAP))


def _run(cmd: list[str], cwd: Path, env: dict[str, str]) -> tuple[int | None, str, str, int]:
    """Exit code (None: hang), stdout, stderr, peak RSS in kB of the case's process."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(cmd, cwd=cwd, env=env, stdout=out, stderr=err, stdin=subprocess.DEVNULL,
                                preexec_fn=_cap)
        t0, code, rss = time.monotonic(), None, 0
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                code, rss = os.waitstatus_to_exitcode(status), usage.ru_maxrss
                proc.returncode = code
                break
            if time.monotonic() - t0 > TIME_LIMIT:
                proc.kill()
                _, _, usage = os.wait4(proc.pid, 0)
                proc.returncode, rss = -9, usage.ru_maxrss
                break
            time.sleep(0.02)
        out.seek(0)
        err.seek(0)
        return code, out.read().decode(errors="replace"), err.read().decode(errors="replace"), rss


def classify(case: dict, code: int | None, stdout: str, stderr: str, rss: int, lost: list[str]) -> list[str]:
    """The defect classes this run shows (empty: clean)."""
    found = []
    if lost:
        found.append("data loss")
    if rss > MEMORY_LIMIT_KB:
        found.append("memory")
    if code is None:
        return found + ["hang"]
    if "Traceback (most recent call last)" in stderr:
        found.append("traceback")
    if "api" in case:
        try:
            result = json.loads(stdout.strip().splitlines()[-1])
        except (ValueError, IndexError):
            return found + ["raw exception"]
        raised, message = result.get("raised"), result.get("message", "")
        if raised not in (None, "NdrqlError"):
            found.append("raw exception")
        if case["expect"] == "refuse" and raised is None:
            found.append("wrong-silent")
        if case["expect"] == "ok" and raised is not None:
            found.append("wrong-silent")
        if raised == "NdrqlError" and case.get("needle") and case["needle"] not in message:
            found.append("misleading")
        return found
    if case["expect"] == "refuse":
        if code == 0:
            return found + ["wrong-silent"]
        lines = stderr.splitlines()
        last = lines[-1] if lines else ""
        errors = [ln for ln in lines if ln.startswith("ndrql: error: ")]
        if code != 2 or len(errors) != 1 or not last.startswith("ndrql: error: ") or any(
                ch in last for ch in "\x1b\x07\r"):  # progress bars may precede the line
            found.append("unclean line")
        if case.get("needle") and not any(case["needle"] in ln for ln in errors):
            found.append("misleading")
    elif case["expect"] == "ok" and (code != 0 or case.get("stdout", "") not in stdout):
        found.append("wrong-silent")
    if any(ch in stdout for ch in "\x1b\x07"):
        found.append("unclean line")
    return found


def run_case(case: dict, fixtures: Path, package: Path) -> dict:
    with tempfile.TemporaryDirectory(prefix="hostile-") as tmp:
        work = Path(tmp)
        for f in fixtures.iterdir():
            (shutil.copytree if f.is_dir() else shutil.copy2)(f, work / f.name)
        for step in case.get("setup", ()):
            plant(work, step)
        env = {**os.environ, "NDRQL_CACHE": str(work / ".cache"), "HOME": str(work), **dict(case.get("env", {}))}
        env.pop("NDRQL_WRITE_PACKAGE", None)
        before = _digests(work, package)
        if "api" in case:
            cmd = [str(PYTHON), "-c", API_RUNNER.format(call=case["api"])]
        else:
            cmd = [str(NDRQL), *case["argv"]]
        t0 = time.monotonic()
        code, stdout, stderr, rss = _run(cmd, work, env)
        after = _digests(work, package)
        allowed = {str(work / a) for a in case.get("allow", ())}  # the outputs the case asks for
        lost = sorted(k for k, v in before.items() if after.get(k) != v and k not in allowed)
        found = classify(case, code, stdout, stderr, rss, lost)
        return {"family": case["family"], "case": case.get("argv") or case.get("api"), "setup": case.get("setup", ()),
                "env": case.get("env", {}), "code": code, "rss_mb": rss // 1024, "seconds": round(time.monotonic() - t0, 1),
                "defects": found, "lost": lost[:5], "stderr": stderr[-400:]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="run one family of cases")
    ap.add_argument("--json", help="write every result here (JSON)")
    ap.add_argument("--list", action="store_true", help="print the cases' count per family and stop")
    args = ap.parse_args(argv)
    package = ROOT / "src" / "ndrql"
    with tempfile.TemporaryDirectory(prefix="hostile-fixtures-") as tmp:
        fixtures = Path(tmp)
        cases = [c for c in all_cases(fixtures) if args.only in (None, c["family"])]
        if args.list:
            print(dict(Counter(c["family"] for c in cases)), len(cases))
            return 0
        results, counts = [], Counter()
        for i, case in enumerate(cases, 1):
            try:
                r = run_case(case, fixtures, package)
            except Exception as exc:  # noqa: BLE001 - the harness's own failure (a setup that needs torch): reported
                print(f"[{i}/{len(cases)}] {case['family']}: harness error {type(exc).__name__}: {exc}", flush=True)
                continue
            results.append(r)
            counts.update(set(r["defects"]))
            if r["defects"]:
                print(f"[{i}/{len(cases)}] {r['family']}: {r['defects']} {str(r['case'])[:160]} {str(r['setup'])[:120]} "
                      f"{str(r['env'])[:80]}\n"
                      f"    {r['stderr'].strip()[-300:]}", flush=True)
    summary = {"cases": len(results), "families": dict(Counter(r["family"] for r in results)),
               "defects": {c: counts.get(c, 0) for c in CLASSES},
               "peak_rss_mb": max((r["rss_mb"] for r in results), default=0),
               "clean": sum(not r["defects"] for r in results)}
    print(json.dumps(summary, indent=1))
    if args.json:
        Path(args.json).write_text(json.dumps({"summary": summary, "results": results}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
