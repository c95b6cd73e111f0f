"""The figures ``ndrql reproduce`` writes beside its tables: Tables 2-3, ``scale``, Fig. 5 and ``sizing``.

Each function draws one figure from results already computed (it runs nothing) on the ``fig`` it is
given, or on a new Agg figure of its own size and layout when none is, and returns it; the experiment
saves it. A *problem* here is a planning problem of the dataset (``blocked``,
``start``, ``goal`` on the planning grid, ``obstacles``, ``source_start``, ``source_goal`` on the
map, ``astar``, ``split``, ``index``, ``category``, and ``region``/``guideline`` on the grid
once predictions are attached); a *run* is a stored :meth:`PlanResult.to_dict`.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from ndrql.maps.area import pixel_bins
from ndrql.maps.grid import cell_to_point
from ndrql.viz.curves import plot_training_curves, plot_validation_curve
from ndrql.viz.maps import figure_or_new, plot_endpoints
from ndrql.viz.overlays import plot_method_paths, plot_prediction
from ndrql.viz.qtable import plot_qtable
from ndrql.viz.style import METHOD_COLORS, row_style


def curves_figure(p: Any, names: Sequence[str], titles: Sequence[str], first_runs: Sequence[Mapping[str, Any]],
                  replays: Sequence[Any], suptitle: str, fig: Any = None) -> Any:
    """Paper Fig. 6 style, one column per method: steps and return per episode of its first run
    (dashed line at convergence), and the Q-table after convergence with the greedy path.

    ``first_runs[j]``: method ``names[j]``'s stored first run (with ``records``), ``titles[j]`` its
    column's title; ``replays[j]``: the same run again with its final Q-table (a ``PlanResult`` with
    ``q_table``, ``path``, ``path_length``).
    """
    n = len(names)
    fig = figure_or_new(fig, (3.2 * n, 9.0), layout="constrained")
    axes = fig.subplots(3, n, squeeze=False)
    for j, (name, run0, r) in enumerate(zip(names, first_runs, replays)):
        color = METHOD_COLORS.get(name)
        if "records" in run0:
            plot_training_curves(axes[0, j], axes[1, j], run0["records"], convergence_episode=run0["convergence_episode"],
                                 color=color)
        axes[0, j].set_title(titles[j], fontsize=9)
        ax = axes[2, j]
        plot_qtable(ax, r.q_table, p.blocked.shape, blocked=p.blocked)
        if r.path:
            pts = np.asarray(r.path, float)
            ax.plot(pts[:, 1], pts[:, 0], "-", color="white", linewidth=1.4)
        plot_endpoints(ax, p.start, p.goal, size=30)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(f"Q-table, path {r.path_length} (A* {p.astar})", fontsize=8)
    fig.suptitle(suptitle, fontsize=10)
    return fig


def maps_figure(problems: Sequence[Any], labels: Sequence[str],
                predictions: Sequence[tuple[np.ndarray | None, np.ndarray | None]],
                paths: Sequence[Mapping[str, Sequence[Sequence[int]] | None]], fig: Any = None) -> Any:
    """Row 1: region (green) and guideline (red) predictions on each map (``predictions[j]`` at the
    map's resolution, ``(None, None)`` for none); row 2: every method's greedy path (``paths[j]``:
    method -> planning cells) on the same planning grid."""
    n = len(problems)
    fig = figure_or_new(fig, (2.6 * n, 6.2), layout="constrained")
    axes = fig.subplots(2, n, squeeze=False)
    for j, (p, label) in enumerate(zip(problems, labels)):
        region, guide = predictions[j]
        plot_prediction(axes[0, j], p.obstacles, region, guide, p.source_start, p.source_goal)
        axes[0, j].set_title(f"{label}\n{p.split} {p.index} {p.category}", fontsize=8)
        plot_method_paths(axes[1, j], p.blocked, paths[j], p.start, p.goal)
    return fig


def scale_figure(agg: Mapping[str, Mapping[str, Any]], names: Sequence[str], fig: Any = None) -> Any:
    """Per category (the groups named ``split/category`` of ``agg``): median convergence steps (bars,
    log scale) and mean optimality gap per method row; an oracle row (``"NDR-QL (oracle priors)"``) is
    drawn hatched in its method's colour beside it."""
    cats = [g for g in agg if "/" in g]
    fig = figure_or_new(fig, (12, 7))
    ax1, ax2 = fig.subplots(2, 1)
    w = 0.8 / len(names)
    x = np.arange(len(cats))
    for i, m in enumerate(names):
        style = row_style(m, i)["bar"]
        ax1.bar(x + i * w, [agg[c][m]["steps"]["median"] or 0 for c in cats], w, label=m, **style)
        ax2.bar(x + i * w, [agg[c][m]["gap"]["mean"] or 0 for c in cats], w, label=m, **style)
    for ax in (ax1, ax2):
        ax.set_xticks(x + 0.4 - w / 2, [c.replace("/", "\n") for c in cats], fontsize=7)
    ax1.set_yscale("log")
    ax1.set_ylabel("median convergence steps")
    ax2.set_ylabel("mean greedy/A* - 1")
    ax1.legend(fontsize=8, ncol=len(names))
    return fig


def scale_distributions(converged: Mapping[str, Sequence[Mapping[str, Any]]], fig: Any = None) -> Any:
    """Distributions over the converged runs of each method row (``converged``: row -> runs):
    convergence steps (ECDF, log x) and optimality gap (histogram); oracle rows dashed."""
    fig = figure_or_new(fig, (12, 4.5))
    ax1, ax2 = fig.subplots(1, 2)
    for i, (m, runs) in enumerate(converged.items()):
        style = row_style(m, i)["line"]
        st = np.sort([r["convergence_steps"] for r in runs])
        if st.size:
            ax1.step(st, np.arange(1, st.size + 1) / st.size, where="post", label=m, **style)
        gaps = [r["length_ratio"] - 1 for r in runs]
        ax2.hist(gaps, bins=np.linspace(0, 1, 41), histtype="step", label=m, **style)
    ax1.set_xscale("log")
    ax1.set_xlabel("convergence steps")
    ax1.set_ylabel("fraction of converged runs")
    ax2.set_xlabel("greedy path / A* - 1")
    ax2.set_ylabel("runs")
    ax2.set_yscale("log")
    ax1.legend(fontsize=8)
    return fig


def dynamic_figure(rows: Sequence[Sequence[tuple[str, Any, Mapping[str, Any]]]], fig: Any = None) -> Any:
    """Fig. 5 with numbers: one row per scenario, one panel per stage ``(title, problem, run)``: the
    predictions on the stage's map and the run's greedy path (white)."""
    n = max(len(row) for row in rows)
    fig = figure_or_new(fig, (2.7 * n, 6.0), layout="constrained")
    axes = fig.subplots(2, n, squeeze=False)
    for r, row in enumerate(rows):
        for i in range(n):
            ax = axes[r, i]
            if i >= len(row):
                ax.axis("off")
                continue
            title, p, run = row[i]
            # upsample the planning-grid predictions for display at map resolution: each pixel shows its cell
            h, w = p.obstacles.shape
            rr, cc = pixel_bins(h, p.blocked.shape[0]), pixel_bins(w, p.blocked.shape[1])
            region = p.region[rr[:, None], cc[None, :]] if p.region is not None else None
            guide = p.guideline[rr[:, None], cc[None, :]] if p.guideline is not None else None
            plot_prediction(ax, p.obstacles, region, guide, p.source_start, p.source_goal)
            if run["path"]:
                pts = np.array([cell_to_point(c, (h, w), p.blocked.shape) for c in run["path"]])
                ax.plot(pts[:, 1], pts[:, 0], "-", color="white", linewidth=1.2)
            ax.set_title(title, fontsize=7)
    return fig


def sizing_figure(curves: Sequence[tuple[str, Sequence[Mapping[str, float]]]], fig: Any = None) -> Any:
    """Validation region and guideline F1 against training hours, one line per run (``curves``:
    ``(label, per-epoch metrics rows)`` with ``train_hours``, ``val_region_f1``, ``val_guideline_f1``);
    a figure of its own is laid out tight."""
    own = fig is None
    fig = figure_or_new(fig, (10, 3.8))
    ax_r, ax_g = fig.subplots(1, 2)
    for label, metrics in curves:
        for ax, key in ((ax_r, "val_region_f1"), (ax_g, "val_guideline_f1")):
            plot_validation_curve(ax, [m["train_hours"] for m in metrics], [m[key] for m in metrics], label=label)
    ax_r.set(xlabel="training hours (one CPU thread)", ylabel="validation region F1 (%)")
    ax_g.set(xlabel="training hours (one CPU thread)", ylabel="validation guideline F1 (%)")
    ax_r.legend(fontsize=7)
    if own:
        fig.tight_layout()
    return fig
