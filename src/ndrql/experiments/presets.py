"""Planning tables under several presets: each method's constants, runs per preset, side-by-side report.

``ndrql reproduce table2|table3|scale|dynamic --preset spec,tuned`` runs the table once per preset
(``spec`` into ``results/<target>/`` as before, any other preset into ``results/<target>-<preset>/``;
both share ``results/predictions/``) and writes ``results/<target>/presets.md``: the headline numbers
of each preset next to each other. Improvements over QL compare methods under the same preset;
the SPEC rows keep the comparison with the paper meaningful, the tuned rows show what each method
reaches when its constants are searched with the same budget (``ndrql tune``). Table 2 is an
ablation of NDR-QL's priors, so there every row runs with the preset's NDR-QL constants.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable, Sequence

from ndrql.experiments import stats
from ndrql.experiments.report import md_table
from ndrql.io import write_text
from ndrql.planning.config import PriorConfig, QLConfig


def method_configs(opts: Any, name: str) -> tuple[QLConfig, PriorConfig]:
    """Constants of method/row ``name`` in a sweep: its preset's entry, else ``opts.ql``/``opts.priors``."""
    preset = getattr(opts, "preset", None)
    if preset is None:
        return opts.ql, opts.priors
    return preset.configs(name)


def out_dir_for(base: Path, preset_name: str) -> Path:
    """``results/<target>`` for spec, ``results/<target>-<preset>`` otherwise (siblings share predictions)."""
    return base if preset_name == "spec" else base.with_name(f"{base.name}-{Path(preset_name).stem}")


def run_presets(target: str, fn: Callable[[Any, Path], Path], opts: Any, out: Path, presets: Sequence[Any],
                log: Callable[[str], None] = print) -> list[Path]:
    """Run ``fn(opts_with_preset, out_dir)`` per preset; with several, also write ``<out>/presets.md``."""
    paths, dirs = [], {}
    for p in presets:
        d = out_dir_for(out, p.name)
        if target == "table2":  # the ablation: every row at NDR-QL's constants, so only the priors differ
            p = p.only("NDR-QL")
        paths.append(fn(replace(opts, preset=p), d))
        dirs[p.name] = d
    if len(presets) > 1 and target in ("table2", "table3", "scale"):
        text = compare(target, dirs)
        paths.append(write_text(out / "presets.md", text))
        log(text)
    return paths


def _load(d: Path) -> dict:
    with open(d / "summary.json") as fh:
        return json.load(fh)


def _pooled(cells: dict, maps: list[str], m: str, ref: str = "QL") -> float | None:
    a = [cells[f"{k}|{m}"]["steps"]["mean"] for k in maps]
    b = [cells[f"{k}|{ref}"]["steps"]["mean"] for k in maps] if all(f"{k}|{ref}" in cells for k in maps) else None
    if b is None or any(x is None for x in a + b):
        return None
    return stats.relative_improvement(a, b)


def compare(target: str, dirs: dict[str, Path]) -> str:
    """Markdown: the headline numbers of each preset's run side by side."""
    names = list(dirs)
    sums = {n: _load(d) for n, d in dirs.items()}
    md = [f"# {target}: presets side by side ({', '.join(names)})", ""]
    pct = lambda x: "-" if x is None else f"{100 * x:.0f}%"  # noqa: E731
    if target == "scale":
        for g in ("all", "seen", "unseen"):
            rows = []
            methods = list(sums[names[0]]["groups"][g])
            for m in methods:
                row = [m]
                for n in names:
                    a = sums[n]["groups"][g][m]
                    row += [stats.fmt(a["steps"]["mean"]), pct(a.get("improvement_pooled")), stats.fmt(a["gap"]["mean"], 3),
                            f"{a['converged']}/{a['runs']}"]
                rows.append(row)
            hdr = ["method"] + [f"{n}: {c}" for n in names for c in ("steps mean", "vs QL (pooled)", "greedy/A* - 1", "converged")]
            md += [f"## {g}", "", md_table(hdr, rows), ""]
        return "\n".join(md) + "\n"
    maps = [m["key"] for m in sums[names[0]]["maps"]]
    methods = list(dict.fromkeys(k.split("|", 1)[1] for k in sums[names[0]]["cells"]))
    rows = []
    for m in methods:
        row = [m]
        for n in names:
            cells = sums[n]["cells"]
            total = sum(cells[f"{k}|{m}"]["steps"]["mean"] or 0 for k in maps)
            ratio = [cells[f"{k}|{m}"]["ratio"]["mean"] for k in maps if cells[f"{k}|{m}"]["ratio"]["mean"] is not None]
            nc = sum(cells[f"{k}|{m}"]["not_converged"] for k in maps)
            row += [stats.fmt(total / len(maps)), pct(_pooled(cells, maps, m)) if m != "QL" else "-",
                    stats.fmt(sum(ratio) / len(ratio), 3) if ratio else "-", str(nc)]
        rows.append(row)
    hdr = ["method"] + [f"{n}: {c}" for n in names for c in ("steps, mean over maps", "vs QL (pooled)", "greedy/A*",
                                                                "not converged")]
    md += [f"{len(maps)} maps ({', '.join(maps)}); per preset the mean over maps of the per-map mean steps, the "
           "pooled improvement over the same preset's QL (when the table has a QL row), the mean greedy path / A*.", "",
           md_table(hdr, rows)]
    return "\n".join(md) + "\n"
