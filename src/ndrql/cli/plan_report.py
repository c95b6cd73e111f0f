"""The text ``ndrql plan`` (and ``ndrql demo``) print: runs, the planning grid, the path on the map, timings."""

from __future__ import annotations

from typing import Any

from ndrql.api import WORK_STAGES
from ndrql.cli.text import text_table
from ndrql.pipeline.belief import belief_lines
from ndrql.pipeline.route import octile_cost
from ndrql.planning.results import geometric_ci, summarize


def fmt(v: Any, nd: int = 0) -> str:
    """``v`` with thousands separators and ``nd`` decimals; ``-`` for ``None``."""
    if v is None:
        return "-"
    return f"{v:,.{nd}f}"


def length_text(px: float, resolution: float | None) -> str:
    """``"1,234 px"`` or ``"1,234 px = 61.7 m"`` on maps with a resolution."""
    return f"{px:,.0f} px" + (f" = {px * resolution:,.2f} m" if resolution is not None else "")


def table(methods: list[str], results: list[Any]) -> list[str]:
    """Per-method table: converged runs, steps (mean, median, 95% CI), episodes, path / A*, short/long episodes.

    Columns are as wide as their widest cell (:func:`ndrql.cli.text.text_table`); a note under the
    table says what ``short/long`` means.
    """
    header = ("method", "conv", "steps mean", "median", "95% CI (geo.)", "episodes", "path/A*", "short/long")
    rows = []
    for m in methods:
        rs = [r for r in results if r.method == m]
        conv = [r for r in rs if r.converged]
        st = summarize([r.convergence_steps for r in conv])
        ep = summarize([r.convergence_episode for r in conv])
        ratio = summarize([r.length_ratio for r in conv])
        short = summarize([r.shortest_success_length for r in conv])
        long_ = summarize([r.longest_success_length for r in conv])
        gci = geometric_ci([r.convergence_steps for r in conv])  # steps are skewed and never negative
        ci = f"[{fmt(gci[0])}, {fmt(gci[1])}]" if gci is not None else "-"
        rows.append((m, f"{len(conv)}/{len(rs)}", fmt(st["mean"]), fmt(st["median"]), ci, fmt(ep["mean"]),
                     fmt(ratio["mean"], 3), fmt(short["mean"]) + "/" + fmt(long_["mean"])))
    note = ("short/long: moves of the shortest and the longest training episode that reached the goal "
            "before convergence (means over the converged runs); 95% CI (geo.): of the geometric mean of the steps")
    return text_table(header, rows) + [note]


def grid_lines(report: Any) -> list[str]:
    """How the map became the planning grid: the rule always, and for the safe grid its cells and size auto's search."""
    setup = report.setup
    if setup is None:
        return []
    if setup.rule != "safe":
        return [f"grid: area, the paper's ({report.grid.shape[0]}x{report.grid.shape[1]} cells area-averaged, a cell "
                f"blocked when at least half obstacle)"]
    res = report.grid_map.resolution
    cell = report.grid.cell_size[0]
    metres = f" = {cell * res:.3g} m" if res is not None else ""
    text = f"grid: safe, square cells of {cell:.2f} px{metres} ({setup.size} on the longer side)"
    if setup.radius_px > 0:
        text += f"; robot radius {length_text(setup.radius_px, res)}"
    lines = [text]
    a = setup.auto
    if a is not None:
        lost = [str(t.size) for t in a.trials if t.ratio is None]
        over = [f"{t.size} ({t.ratio:.3f}x)" for t in a.trials if t.ratio is not None and t.size != a.size]
        tail = "; ".join(x for x in (f"{', '.join(lost)}: no route" if lost else "",
                                     f"too long: {', '.join(over)}" if over else "") if x)
        lines.append(f"size auto: route on the grid {a.chosen.ratio:.3f} x the map's shortest "
                     f"({length_text(a.full_length, res)}), tolerance {a.tolerance:.0%}" + (f" ({tail})" if tail else ""))
    return lines


def route_lines(report: Any) -> list[str]:
    """The learned paths on the full map: collisions (always shown), lengths before and after smoothing."""
    res = report.grid_map.resolution
    lines = []
    single = len(report.results) == 1
    area = report.setup is not None and report.setup.rule == "area"
    for m in report.methods:
        runs = [r for r in report.runs(m) if r.route is not None]
        bad = [r for r in runs if r.route.collides]
        if bad:
            r = bad[0]
            seg, (pr, pc) = r.route.final_collisions[0]
            who = f"{m} seed {r.seed}" if single or len(bad) == 1 else f"{m}: {len(bad)} of {len(runs)} runs; seed {r.seed}"
            hint = " (the paper's area grid lets paths clip obstacles; --grid safe does not)" if area else ""
            lines.append(f"{who}: path collides: {len(r.route.final_collisions)} of {len(r.route.pixels) - 1} segments "
                         f"cross obstacles on the full map (first at pixel ({pr}, {pc})); not a success{hint}")
        elif runs and not area:
            r = runs[0]
            what = "smoothed" if r.route.smoothed else "not smoothed"
            who = f"{m} seed {r.seed}" if single else f"{m}: {len(runs)} of {len(runs)} paths collision-free; seed {r.seed}"
            lines.append(f"{who}: path on the map collision-free; grid path {length_text(r.route.grid_length, res)}, "
                         f"{what} {length_text(r.route.length, res)}" + _vs_full(report, r.route))
    return lines


def prediction_lines(report: Any) -> list[str]:
    """The sources asked and the judge's verdicts, and which method ran when every source was rejected.

    Shown when a source was rejected or a fallback ran, and on the safe grid; the paper's setting keeps its
    output (the JSON always has ``sources`` and ``prediction_quality``)."""
    q = report.info.get("prediction_quality")
    if q is None:
        return []
    fb = report.info.get("fallback")
    trials = report.info.get("sources") or []
    if q["informative"]:
        if report.setup is None or report.setup.rule != "safe":
            return []
        return [sources_text(trials)]
    if fb:
        exact = " (the exact BFS distance)" if fb["ran"] == "IQL-BFS" else ""
        return [f"{sources_text(trials)}; {', '.join(fb['requested'])} fell back to {fb['ran']}{exact}; "
                f"--fallback none keeps the model's priors"]
    return [f"{sources_text(trials)}; the rejected priors were used anyway (--fallback none)"]


def sources_text(trials: list[dict[str, Any]]) -> str:
    """The JSON's ``sources`` as one line: each source asked, accepted or rejected and why."""
    parts = []
    for t in trials:
        if t["accepted"]:
            ratio = t.get("route_ratio")
            on = t.get("guideline_on_obstacles")
            parts.append(f"{t['source']} accepted (Eq. 7 threshold {t['threshold']:.2f}"
                         + (f", its route {ratio:.2f}x the shortest" if ratio is not None else "")
                         + (f", {on:.0%} of the guideline on obstacles" if on is not None else "") + ")")
        else:
            parts.append(f"{t['source']} rejected ({t['reason']})")
    return "prediction: " + ("; ".join(parts) if parts else "no source asked")


def _vs_full(report: Any, route: Any) -> str:
    """The final path against the map's own optimum, one definition everywhere (as the scenario batch's
    ratio): the path's octile cost over the octile length of the map's shortest 8-connected route."""
    a = report.setup.auto if report.setup is not None else None
    if a is None or a.full_length <= 0:
        return ""
    return f" (octile cost {octile_cost(route.pixels) / a.full_length:.3f} x the map's octile optimum)"


def run_name(r: Any) -> str:
    """A run's method, and the one asked for when the fallback replaced it: ``IQL (fallback for NDR-QL)``."""
    asked = getattr(r, "requested_method", None)
    return r.method if asked in (None, r.method) else f"{r.method} (fallback for {asked})"


def no_threshold(report: Any, name: str) -> str:
    """The summary's word for ``name``'s missing NDR-QI threshold, with the report's reason
    (:meth:`~ndrql.pipeline.report.PlanReport.threshold_reason`)."""
    why = report.threshold_reason(name) if hasattr(report, "threshold_reason") else None
    return f"none ({why or 'mask 0 everywhere'})"


def summary_lines(report: Any) -> list[str]:
    """The short summary printed by ``plan``: runs, A* optimum, NDR-QI threshold, path on the map, time per stage."""
    lines = grid_lines(report)
    opt = report.astar_length
    single = len(report.methods) == 1 and len(report.seeds) <= 3
    if single:
        for r in report.results:
            if r.converged:
                lines.append(f"{run_name(r)} seed {r.seed}: converged after {r.convergence_episode:,} episodes, "
                             f"{r.convergence_steps:,} steps; path {r.path_length} moves ({r.length_ratio:.3f} x A*)")
            else:
                tail = f"; last greedy path {r.path_length} moves" if r.path_length is not None else ""
                lines.append(f"{run_name(r)} seed {r.seed}: NOT converged in {r.episodes:,} episodes "
                             f"({r.total_steps:,} steps){tail}")
    lines.append(f"A* optimum: {opt} moves; seeds {report.seeds[0]}..{report.seeds[-1]}; "
                 f"max {report.config.max_episodes} episodes")
    lines += belief_lines(report.info)
    if not single:
        lines += table(list(report.methods), list(report.results))
    through = str(report.info.get("qi_distance", "")).startswith("moves through the region")
    for name, thd in report.thresholds.items():
        lines.append(f"{name}: NDR-QI threshold {f'{thd:.2f}' if thd is not None else no_threshold(report, name)}"
                     + (f"; Eq. 6's distance: {report.info['qi_distance']}" if through else ""))
    if "IQL-NDR" in report.methods and report.info.get("qi_distance"):  # Eq. 5 on the prior source's distance
        lines.append(f"IQL-NDR: Eq. 5's distance from the prior source: {report.info['qi_distance']}")
    not_conv = sum(not r.converged for r in report.results)
    if not_conv:
        lines.append(f"{not_conv} of {len(report.results)} runs did not converge (reported, not dropped)")
    lines += prediction_lines(report)
    lines += route_lines(report)
    t = report.timings
    stages = ", ".join(f"{s} {t[s]:.3f}" for s in WORK_STAGES)
    extra = "".join(f", {s} {t[s]:.3f}" for s in ("grid", "route") if t.get(s, 0.0) >= 0.0005)
    kernels = {"c": ", C kernels", "numba": ", numba kernels"}.get(report.info.get("kernels", ""), "")
    lines.append(f"time (s): {stages}; work {report.work_time:.3f} "
                 f"(+ map {t['map']:.3f}{extra}, start-up {t['startup']:.2f}{kernels})")
    return lines
