#!/usr/bin/env python3
"""Regenerate the README's demo picture, demo table and example `plan` output with the shipped weights.

    .venv/bin/python tools/refresh_readme.py      # runs `ndrql demo` and one `ndrql plan`, rewrites README.md

Writes ``docs/demo.png`` (from ``out/demo/compare.png``) and replaces the text between the
``<!-- demo:start -->``/``<!-- demo:end -->`` and ``<!-- plan:start -->``/``<!-- plan:end -->``
markers. Run it after the default shipped weights (``--weights general``) change.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

from ndrql.version import DOCS_URL

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
EXE = str(Path(sys.executable).with_name("ndrql"))
PLAN = ["plan", "--example", "--png", "out/plan.png"]


def run(args: list[str]) -> str:
    env = {k: v for k, v in os.environ.items() if k != "NDRQL_WEIGHTS"}  # the shipped weights
    r = subprocess.run([EXE, *args], capture_output=True, text=True, cwd=ROOT, env=env)
    if r.returncode != 0:
        sys.exit(f"ndrql {' '.join(args)} failed:\n{r.stderr}")
    return r.stdout


def weights_commit() -> str:
    """The commit of the default weights file (``ndrql.model.weights.DEFAULT_WEIGHTS``)."""
    from ndrql.model.weights import resolve_weights

    path = resolve_weights(None).resolve().relative_to(ROOT)
    r = subprocess.run(["git", "log", "-1", "--format=%h", "--", str(path)], capture_output=True, text=True, cwd=ROOT)
    return r.stdout.strip() or "uncommitted"


def replace(text: str, tag: str, body: str) -> str:
    pat = re.compile(rf"(<!-- {tag}:start[^>]*-->\n).*?(<!-- {tag}:end -->)", re.S)
    if not pat.search(text):
        sys.exit(f"README.md has no <!-- {tag}:start --> ... <!-- {tag}:end --> markers")
    return pat.sub(lambda m: m.group(1) + body + m.group(2), text)


def main() -> int:
    run(["demo", "--out", "out/demo"])
    from ndrql.io import write_bytes

    write_bytes(ROOT / "docs" / "demo.png", (ROOT / "out" / "demo" / "compare.png").read_bytes())
    data = json.loads((ROOT / "out" / "demo" / "results.json").read_text())
    table = (ROOT / "out" / "demo" / "table.md").read_text().split("\n\n", 1)[1].strip()
    mean = {m: data["summary"][m]["convergence_steps"]["mean"] for m in data["methods"]}
    ratio = {m: data["summary"][m]["length_ratio"]["mean"] for m in data["methods"]}
    commit = weights_commit()
    summary = textwrap.fill(
        f"On this map NDR-QL needs {mean['NDR-QL'] / mean['QL']:.2f}x the convergence steps of QL and "
        f"{mean['NDR-QL'] / mean['IQL']:.2f}x those of IQL (mean path / A\\*: NDR-QL {ratio['NDR-QL']:.3f}, "
        f"QL {ratio['QL']:.3f}, IQL {ratio['IQL']:.3f}). One map and one set of weights: see "
        f"[docs/results.md]({DOCS_URL}/results.md) for many maps.", 100, break_on_hyphens=False, break_long_words=False)
    demo = (f"Weights of commit {commit}; seeds {data['seeds'][0]}..{data['seeds'][-1]}, A\\* optimum "
            f"{data['astar_length']} moves, NDR-QI threshold {data['ndr_qi_threshold']['NDR-QL']:.2f} "
            f"(`out/demo/table.md`):\n\n{table}\n\n{summary}\n")
    out = run(PLAN)
    plan = (f"```\n$ ndrql {' '.join(PLAN)}\n{out.rstrip()}\n```\n\n"
            f"(weights of commit {commit}; the numbers move with the weights and the seed.)\n")
    text = replace(replace(README.read_text(encoding="utf-8"), "demo", demo), "plan", plan)
    from ndrql.io import write_text

    write_text(README, text)
    print(f"updated {README} and docs/demo.png (weights of commit {commit})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
