"""Helpers for the result files: machine description, markdown tables, figure saving."""

from __future__ import annotations

import datetime as _dt
import os
import platform
import subprocess
from pathlib import Path
from typing import Any, Sequence


def machine() -> dict[str, Any]:
    """CPU, cores, load, versions and git commit: what a reader needs to judge timings."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    info: dict[str, Any] = {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "load_avg": [round(x, 2) for x in os.getloadavg()] if hasattr(os, "getloadavg") else None,
        "python": platform.python_version(),
        "date": _dt.datetime.now().strftime("%Y-%m-%d %H:%M"),
    }
    for mod in ("numpy", "numba", "torch", "scipy"):
        try:
            info[mod] = __import__(mod).__version__
        except Exception:  # pragma: no cover - optional
            pass
    try:
        here = Path(__file__).resolve().parent
        info["git"] = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=here, capture_output=True,
                                     text=True, timeout=5).stdout.strip() or None
    except (OSError, subprocess.SubprocessError):
        info["git"] = None
    return info


def machine_line(info: dict[str, Any]) -> str:
    load = info.get("load_avg")
    return (f"{info['date']}, {info['cpu']}, {info['cores']} logical cores (load average at start "
            f"{load[0] if load else '?'}), Python {info['python']}, numpy {info.get('numpy')}, "
            f"numba {info.get('numba')}, torch {info.get('torch', '-')}, git {info.get('git')}")


def md_table(header: Sequence[str], rows: Sequence[Sequence[Any]], align: Sequence[str] | None = None) -> str:
    """A GitHub markdown table; ``align`` per column is ``l`` or ``r`` (default: first l, rest r)."""
    align = align or ["l"] + ["r"] * (len(header) - 1)
    sep = ["---" if a == "l" else "---:" for a in align]
    lines = ["| " + " | ".join(str(h) for h in header) + " |", "| " + " | ".join(sep) + " |"]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def save_figure(fig: Any, path: str | Path, dpi: int = 110) -> Path:
    """Write ``fig`` to ``path`` (format from the extension, tight bounding box) and return the path."""
    from ndrql.io import save_figure as io_save_figure

    return io_save_figure(fig, path, dpi=dpi, bbox_inches="tight")
