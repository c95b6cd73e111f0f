"""The markdown of the result files: machine description, tables, headers and cells, figure saving.

Every table of ``ndrql reproduce`` is rendered with these pieces; the numbers come from the
experiment modules, the figures from :mod:`ndrql.viz.reproduce`.
"""

from __future__ import annotations

import datetime as _dt
import os
import platform
import subprocess
from pathlib import Path
from dataclasses import asdict
from typing import Any, Sequence

from ndrql.io import save_figure as io_save_figure
from ndrql.io import write_json, write_text
from ndrql.planning.preset import configs_dict

#: Footnote of Tables 1 and 4 on the unseen region labels.
UNSEEN_NOTE = ("unseen R scores the 300 NARROW PASSAGE samples against region labels regenerated from the guideline "
               "(the upstream ones are broken: docs/dataset.md); 'original labels' scores the same predictions "
               "against the upstream labels resized to 201 px, as the paper presumably did.")


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
    return io_save_figure(fig, path, dpi=dpi, bbox_inches="tight")


def pct(x: float | None) -> str:
    """A fraction as a whole percentage, ``-`` when missing."""
    return "-" if x is None else f"{100 * x:.0f}%"


# ------------------------------------------------------------------------------ planning tables


def preset_line(opts: Any, names: Sequence[str]) -> str:
    """One paragraph for a table's header: the preset of ``opts`` and each row's searched constants."""
    preset = getattr(opts, "preset", None)
    if preset is None:
        return ""
    parts = []
    for n in names:
        ql, pc = preset.configs(n)
        d = configs_dict(ql, pc)
        vals = {**d["ql"], **d["priors"]}
        parts.append(f"{n}: " + ", ".join(f"{k} {v:.4g}" for k, v in vals.items()))
    return f"Preset **{preset.name}** ({preset.source or 'given'}); constants per row: " + "; ".join(parts) + "."


def planning_header(title: str, opts: Any, info: dict, predictions: Any, extra: str = "",
                    names: Sequence[str] = ()) -> str:
    """Header of a planning table: command, machine, seeds, constants (or preset), NDR weights.

    ``opts``: the table's :class:`~ndrql.experiments.planning_runs.SweepOptions`; ``predictions``:
    its prediction cache (``weights``, ``digest``), the oracle's priors or ``None``; ``names``: the table's rows.
    """
    lines = [f"# {title}", "", f"Command: `{opts.command}`" if opts.command else "", "",
             f"Machine: {machine_line(info)}.", "",
             f"Seeds {opts.seed0}..{opts.seed0 + opts.seeds - 1} per map and method; QLConfig {asdict(opts.ql)}; "
             f"PriorConfig {asdict(opts.priors)}."]
    if getattr(predictions, "prior_from", None) == "oracle":
        lines += ["", f"NDR priors: **{predictions.weights}** in place of a model: region and guideline drawn from each "
                  "planning grid's 8-connected shortest path with line-of-sight shortcuts, as the dataset draws its labels (a diagnostic, not a method)."]
    elif predictions is not None:
        lines += ["", f"NDR weights: `{predictions.weights}` (sha256 {predictions.digest})."]
    if opts.preset is not None:
        lines[6] = f"Seeds {opts.seed0}..{opts.seed0 + opts.seeds - 1} per map and method."
        lines += ["", preset_line(opts, names)]
    if extra:
        lines += ["", extra]
    return "\n".join(lines) + "\n"


#: What the share tables say about the oracle row and the share (tables 3 and scale).
SHARE_NOTE = ("*{oracle}* is {row} with the **oracle's priors** in place of the model's: region and guideline drawn from "
              "an 8-connected shortest path of each planning grid with line-of-sight shortcuts, as the dataset draws its labels, then Eqs. 3-7 as for the model "
              "(a diagnostic of a perfect prediction, not a method); same maps, seeds and constants. Share of the oracle's "
              "reduction = (1 - {row}/QL) / (1 - oracle/QL) on steps pooled over the same maps and seeds (a run that did not "
              "converge counts the steps it ran); steps below are per run, every run.")


def share_section(shares: dict[str, dict[str, Any]], row: str, oracle: str, seeds: int,
                  first: str = "group") -> list[str]:
    """The markdown section of a table's share of the oracle's reduction: heading, note and :func:`share_table`."""
    return ["\n## Share of the oracle's reduction\n", SHARE_NOTE.format(oracle=oracle, row=row) + "\n",
            share_table(shares, row, oracle, seeds, first)]


def share_table(shares: dict[str, dict[str, Any]], row: str, oracle: str, seeds: int, first: str = "group") -> str:
    """One line per group (or map: ``first`` names the column) of
    :func:`~ndrql.experiments.planning_runs.oracle_share` results: steps per run of QL, ``row`` and ``oracle``,
    their change against QL and the share."""
    header = [first, "maps", "QL steps", f"{row} steps", "oracle steps", f"{row} vs QL", "oracle vs QL",
              "share of oracle"]
    rows = []
    for name, sh in shares.items():
        runs = sh["maps"] * seeds
        share = sh["share"]
        rows.append([name, sh["maps"], *(f"{sh['steps'][n] / runs:,.0f}" for n in ("QL", row, oracle)),
                     f"{100 * sh['vs_ql'][row]:+.1f}%", f"{100 * sh['vs_ql'][oracle]:+.1f}%",
                     "-" if share != share else f"{100 * share:.0f}%"])
    return md_table(header, rows)


# --------------------------------------------------------------------------------- model tables


def fmt_f1(x: float | None, digits: int = 2) -> str:
    """An F1 (or hours, parameters) with ``digits`` decimals, ``-`` when missing or NaN."""
    return "-" if x is None or x != x else f"{x:.{digits}f}"


def f1_cells(r: dict[str, dict[str, float]]) -> list[str]:
    """Seen R, seen G, unseen R, unseen G and unseen R against the original labels of an evaluation."""
    return [fmt_f1(r["seen"]["region_f1"]), fmt_f1(r["seen"]["guideline_f1"]), fmt_f1(r["unseen"]["region_f1"]),
            fmt_f1(r["unseen"]["guideline_f1"]), fmt_f1(r["unseen"]["region_f1_original"])]


def f1_header(title: str, command: str, limit: int | None) -> list[str]:
    """Header lines of a model table (Tables 1 and 4)."""
    return [f"# {title}", "", f"Command: `{command}`", "", f"Machine: {machine_line(machine())}.", "",
            f"Samples per split: {limit or 'all (1,200)'}; F1 per docs/method.md via ndrql.training.evaluate.", ""]


def write_table(out_dir: Path, name: str, lines: list[str], numbers: dict) -> Path:
    """``<out_dir>/<name>.md`` from ``lines`` and ``<out_dir>/summary.json`` from ``numbers``; the markdown path."""
    path = write_text(out_dir / f"{name}.md", "\n".join(lines) + "\n")
    write_json(out_dir / "summary.json", numbers, indent=None, strict=False)
    return path
