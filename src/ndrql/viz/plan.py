"""Pictures of a plan: the map with the NDR region and guideline, the learned path and the A* path;
a side-by-side comparison of methods; convergence steps per method.

Plot functions draw on a given ``ax`` and return their artists; none calls ``show``. The figure
builders (:func:`plan_figure`, :func:`compare_figure`) draw on the ``ax`` or ``fig`` they are given,
or on a new Agg ``Figure`` sized for the map when none is, and return the figure for the caller to
save. Paths are planning-grid cells, drawn at their centres in map pixels.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from ndrql.maps.astar import astar4
from ndrql.maps.grid import cell_to_point
from ndrql.planning.methods import get_method
from ndrql.viz.maps import frame_map, new_figure, plot_endpoints, plot_occupancy, plot_path

from ndrql.viz.style import (ASTAR_COLOR, BLOCKED_ALPHA, BLOCKED_COLOR, GUIDELINE_RGB, METHOD_COLORS,  # noqa: F401
                              REGION_RGB, legend_below, method_color)


def plot_probability(ax: Any, prob: np.ndarray, rgb: Sequence[float], *, max_alpha: float = 0.65, floor: float = 0.2,
                     zorder: int = 1) -> Any:
    """``prob`` (0..1, map pixels) as one colour whose opacity grows linearly from 0 at ``floor`` to
    ``max_alpha`` at 1 (below ``floor``: transparent); returns the image."""
    a = np.clip((np.asarray(prob, dtype=np.float64) - floor) / (1.0 - floor), 0.0, 1.0)
    img = np.zeros(a.shape + (4,))
    img[..., :3] = rgb
    img[..., 3] = a * max_alpha
    h, w = a.shape
    return ax.imshow(img, interpolation="nearest", extent=(-0.5, w - 0.5, h - 0.5, -0.5), zorder=zorder)


def plot_plan(
    ax: Any,
    obstacles: np.ndarray,
    blocked: np.ndarray,
    source_start: Sequence[int],
    source_goal: Sequence[int],
    *,
    path: Sequence[Sequence[int]] | None = None,
    astar_path: Sequence[Sequence[int]] | None = None,
    region: np.ndarray | None = None,
    guideline: np.ndarray | None = None,
    label: str = "learned path",
    color: str = "tab:red",
    title: str | None = None,
    legend: bool = True,
    cell_size: Sequence[float] | None = None,
    route: Any = None,
    prior_source: str = "NDR",
) -> list[Any]:
    """The map, the planning grid's blocked cells, region (green) and guideline (orange) probabilities,
    the A* path (blue, dashed) and the learned path; returns every artist drawn.

    ``obstacles``, ``region`` and ``guideline`` are at the map's resolution; ``blocked`` and both
    paths on the planning grid (``(row, col)`` cells). ``cell_size``: cell side (rows, cols) in map
    pixels (default: the map's size over the grid's, the area grid). ``route``: the learned path on
    the map (:class:`~ndrql.pipeline.route.Route`): its final path is drawn solid over a thin grid
    path, and every collision with an obstacle as a red cross. ``prior_source``: what made region and guideline,
    for the legend ("NDR" for the network, "exact" for the exact prior, ...).
    """
    from matplotlib.patches import Patch

    obstacles = np.asarray(obstacles, dtype=bool)
    blocked = np.asarray(blocked, dtype=bool)
    h, w = obstacles.shape
    extent = (-0.5, w - 0.5, h - 0.5, -0.5)
    if cell_size is not None:
        extent = (-0.5, blocked.shape[1] * cell_size[1] - 0.5, blocked.shape[0] * cell_size[0] - 0.5, -0.5)
    # predictions first, then the map on top of them so obstacles stay crisp
    artists: list[Any] = [plot_occupancy(ax, obstacles, color="black", zorder=2)]
    artists.append(plot_occupancy(ax, blocked, color=BLOCKED_COLOR, alpha=BLOCKED_ALPHA, extent=extent, zorder=2))
    keys = [Patch(color="black", label="obstacle"), Patch(color=BLOCKED_COLOR, alpha=BLOCKED_ALPHA, label="blocked cell")]
    if region is not None:
        artists.append(plot_probability(ax, region, REGION_RGB, max_alpha=0.45))
        keys.append(Patch(color=REGION_RGB, alpha=0.45, label=f"{prior_source} region"))
    if guideline is not None:
        artists.append(plot_probability(ax, guideline, GUIDELINE_RGB, max_alpha=0.85))
        keys.append(Patch(color=GUIDELINE_RGB, alpha=0.85, label=f"{prior_source} guideline"))

    def px(cells: Sequence[Sequence[int]]) -> list[tuple[float, float]]:
        if cell_size is None:
            return [cell_to_point(c, (h, w), blocked.shape) for c in cells]
        return [((r + 0.5) * cell_size[0] - 0.5, (c + 0.5) * cell_size[1] - 0.5) for r, c in cells]

    if astar_path:
        artists += plot_path(ax, px(astar_path), color=ASTAR_COLOR, linewidth=1.5,
                             label=f"A* ({len(astar_path) - 1} moves)", zorder=3)
        artists[-1].set_linestyle("--")
    smoothed = route is not None and route.smoothed
    if path:
        artists += plot_path(ax, px(path), color=color, linewidth=1.0 if smoothed else 2.0,
                             label=f"{label} ({len(path) - 1} moves)", zorder=4)
        if smoothed:
            artists[-1].set_linestyle(":")
    if smoothed:
        artists += plot_path(ax, route.pixels, color=color, linewidth=2.0, label=f"{label}, smoothed on the map", zorder=5)
    if route is not None and route.final_collisions:
        hits = np.asarray([p for _, p in route.final_collisions], dtype=float)
        artists.append(ax.scatter(hits[:, 1], hits[:, 0], s=70, c="red", marker="x", linewidths=2.0, zorder=6,
                                  label=f"collision ({len(hits)})"))
    artists += plot_endpoints(ax, source_start, source_goal)
    frame_map(ax, (h, w))
    if title:
        artists.append(ax.set_title(title, fontsize=9))
    if legend:
        handles, _ = ax.get_legend_handles_labels()
        artists.append(legend_below(ax, handles + keys))
    return artists


def plot_convergence(ax: Any, steps: Mapping[str, Sequence[int | None]], *, title: str | None = None) -> list[Any]:
    """Convergence steps per method: one dot per seed, a bar at the mean; runs that did not converge
    (``None``) are counted in the tick label. Returns the artists."""
    artists: list[Any] = []
    names = list(steps)
    rng = np.random.default_rng(0)  # horizontal jitter only, fixed so figures are reproducible
    for i, name in enumerate(names):
        vals = np.asarray([v for v in steps[name] if v is not None], dtype=float)
        c = method_color(name, i)
        if vals.size:
            artists.append(ax.bar(i, vals.mean(), width=0.6, color=c, alpha=0.35, zorder=1))
            artists.append(ax.scatter(i + rng.uniform(-0.18, 0.18, vals.size), vals, s=14, color=c, zorder=2))
    ax.set_xticks(range(len(names)))
    labels = []
    for name in names:
        n_nc = sum(v is None for v in steps[name])
        labels.append(f"{name}\n{n_nc} not conv." if n_nc else name)
    ax.set_xticklabels(labels, fontsize=8)
    ax.set_ylabel("convergence steps")
    ax.ticklabel_format(axis="y", style="sci", scilimits=(0, 0))
    ax.set_ylim(bottom=0)
    ax.grid(axis="y", alpha=0.3)
    if title:
        artists.append(ax.set_title(title, fontsize=9))
    return artists


def _astar(report: Any) -> list[list[int]]:
    return [list(c) for c in astar4(report.grid.blocked, report.grid.start, report.grid.goal).path]


def _run_title(r: Any) -> str:
    asked = getattr(r, "requested_method", None)
    name = r.method if asked in (None, r.method) else f"{r.method} (fallback for {asked})"
    collides = getattr(r, "route", None) is not None and r.route.collides
    tail = f"; PATH COLLIDES ({len(r.route.final_collisions)} segments)" if collides else ""
    if r.converged:
        return (f"{name} seed {r.seed}: converged, {r.convergence_steps:,} steps\n"
                f"path {r.path_length} moves = {r.length_ratio:.2f} x A*{tail}")
    return f"{name} seed {r.seed}: NOT converged in {r.episodes:,} episodes{tail}"


def _grid_kw(report: Any, r: Any) -> dict[str, Any]:
    """The cell size of square (safe) grids and the run's route, for :func:`plot_plan`."""
    kw: dict[str, Any] = {"route": getattr(r, "route", None)}
    if report.grid.cell_px is not None:
        kw["cell_size"] = report.grid.cell_size
    return kw


def _source(report: Any) -> str:
    """The legend's name of what made the report's region: "NDR" for the network, else the source's name."""
    src = ((report.info or {}).get("prediction_quality") or {}).get("source")
    return "NDR" if src in (None, "model", "file") else str(src)


def plan_figure(report: Any, method: str | None = None, seed: int | None = None, dpi: int = 110,
                ax: Any = None) -> Any:
    """One run of a :class:`~ndrql.api.PlanReport` over the map, with the NDR overlay if predicted; drawn
    on ``ax`` (or on a new figure sized for the map, laid out tight, at ``dpi``). Returns the figure."""
    r = next(x for x in report.results if (method is None or x.method == method) and (seed is None or x.seed == seed))
    own = ax is None
    if own:
        h, w = report.grid_map.shape
        fig = new_figure(figsize=(5.2, min(9.0, max(2.5, 5.2 * h / w)) + 1.3), dpi=dpi)  # room for title and legend
        ax = fig.add_subplot(1, 1, 1)
    plot_plan(ax, report.grid_map.obstacles, report.grid.blocked, report.grid.source_start, report.grid.source_goal,
              path=r.path, astar_path=_astar(report), region=report.region, guideline=report.guideline, prior_source=_source(report),
              label=r.method, color=method_color(r.method), title=_run_title(r), **_grid_kw(report, r))
    if own:
        ax.figure.tight_layout()
    return ax.figure


def compare_figure(report: Any, dpi: int = 110, fig: Any = None) -> Any:
    """Every method's first-seed path side by side (NDR overlay on the NDR methods' panels) and,
    with several seeds, a last panel of convergence steps; drawn on ``fig`` (or on a new figure sized
    for the panels, laid out tight, at ``dpi``). Returns the figure."""
    methods = list(report.methods)
    with_steps = len(report.seeds) > 1
    n = len(methods) + int(with_steps)
    own = fig is None
    if own:
        h, w = report.grid_map.shape
        fig = new_figure(figsize=(4.2 * n, min(7.0, max(2.0, 4.2 * h / w)) + 1.4), dpi=dpi)
    best = _astar(report)
    for i, name in enumerate(methods):
        ax = fig.add_subplot(1, n, i + 1)
        r = report.runs(name)[0]
        ndr = get_method(name).needs_ndr
        plot_plan(ax, report.grid_map.obstacles, report.grid.blocked, report.grid.source_start, report.grid.source_goal,
                  path=r.path, astar_path=best, region=report.region if ndr else None, prior_source=_source(report),
                  guideline=report.guideline if ndr else None, label=name, color=method_color(name, i),
                  title=_run_title(r), **_grid_kw(report, r))
    if with_steps:
        ax = fig.add_subplot(1, n, n)
        plot_convergence(ax, {m: [r.convergence_steps for r in report.runs(m)] for m in methods},
                         title=f"convergence steps, {len(report.seeds)} seeds")
    if own:
        fig.tight_layout()
    return fig
