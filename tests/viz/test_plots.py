"""Every plot function draws on a bare ``matplotlib.figure.Figure`` (no pyplot, no backend) and returns its artists.

The figure builders (``viz.plan.plan_figure`` and ``compare_figure``, ``viz.reproduce``'s builders,
``viz.sheet.contact_sheet``) draw on the ``ax`` or ``fig`` they are given and return the figure; only
without one do they make their own (an Agg figure of their size).
"""

from __future__ import annotations

import ast
import io
import sys
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colorbar import Colorbar
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure

import ndrql
from ndrql.maps.grid import cell_to_point
from ndrql.pipeline.settings import PlanSettings
from ndrql.planning.runner import run_plan
from ndrql.viz import curves, maps, overlays, qtable, sheet, style
from ndrql.viz import plan as viz_plan
from ndrql.viz import prediction as viz_prediction
from ndrql.viz import reproduce as viz_reproduce

from helpers import REPO_ROOT


def _pyplot_figures() -> list[int]:
    plt = sys.modules.get("matplotlib.pyplot")
    return list(plt.get_fignums()) if plt is not None else []


@pytest.fixture
def fig():
    """A bare ``Figure``; the test fails if drawing on it opened a pyplot figure."""
    before = _pyplot_figures()
    yield Figure()
    assert _pyplot_figures() == before, "a plot function used pyplot"


def _grid():
    b = np.zeros((20, 20), bool)
    b[10, :15] = True
    return b, (0, 0), (19, 0)


def _labels(ax) -> list[str]:
    legend = ax.get_legend()
    return [t.get_text() for t in legend.get_texts()] if legend is not None else []


def test_viz_modules_never_import_pyplot():
    for path in sorted((REPO_ROOT / "src" / "ndrql" / "viz").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [f"{node.module}.{a.name}" for a in node.names] if isinstance(node, ast.ImportFrom) else [])
            assert not any(n.startswith("matplotlib.pyplot") for n in names), path.name


def test_new_figure_is_an_agg_figure_of_the_asked_size():
    before = _pyplot_figures()
    f = maps.new_figure(figsize=(2.0, 1.0), dpi=50)
    assert isinstance(f, Figure) and isinstance(f.canvas, FigureCanvasAgg)
    assert f.canvas.get_width_height() == (100, 50) and _pyplot_figures() == before


def test_map_layers_in_pixel_coordinates(fig):
    ax = fig.add_subplot(1, 1, 1)
    obstacles = np.zeros((6, 8), bool)
    obstacles[2, 3] = True
    img = maps.plot_occupancy(ax, obstacles)
    assert np.array_equal(img.get_array(), obstacles.astype(np.uint8))
    assert tuple(img.get_extent()) == (-0.5, 7.5, 5.5, -0.5)  # pixel (row, col) centred at x = col, y = row
    (line,) = maps.plot_path(ax, [(0, 0), (5, 7)])
    assert list(line.get_xdata()) == [0, 7] and list(line.get_ydata()) == [0, 5]
    start, goal = maps.plot_endpoints(ax, (1, 2), (4, 6))
    assert start.get_offsets().tolist() == [[2, 1]] and goal.get_offsets().tolist() == [[6, 4]]
    assert start.get_label() == "start" and goal.get_label() == "goal"
    maps.frame_map(ax, obstacles.shape)
    assert ax.get_xlim() == (-0.5, 7.5) and ax.get_ylim() == (5.5, -0.5)  # row 0 on top
    assert list(ax.get_xticks()) == [] and list(ax.get_yticks()) == []


def test_planning_result_draws_the_astar_path_at_cell_centres(fig):
    ax = fig.add_subplot(1, 1, 1)
    obstacles = np.zeros((40, 60), bool)
    blocked = np.zeros((4, 6), bool)
    cells = [(0, 0), (0, 1), (1, 1)]
    artists = maps.plot_planning_result(ax, obstacles, blocked, cells, (3, 4), (15, 14), title="t")
    (path,) = [a for a in artists if getattr(a, "get_linestyle", lambda: "")() == "--"]
    expected = [cell_to_point(c, obstacles.shape, blocked.shape) for c in cells]
    assert list(zip(path.get_ydata(), path.get_xdata())) == expected
    assert _labels(ax) == ["A* (2 moves)", "start", "goal", "obstacle", "blocked cell"]
    assert ax.get_title() == "t"


def test_episode_curve_smooths_and_marks_convergence(fig):
    ax = fig.add_subplot(1, 1, 1)
    line, vline, note = curves.plot_episode_curve(ax, [3, 6, 9, 12], convergence_episode=2, smooth=3)
    assert list(line.get_xdata()) == [3, 4] and list(line.get_ydata()) == pytest.approx([6.0, 9.0])
    assert list(vline.get_xdata()) == [2, 2] and vline.get_linestyle() == "--" and note.get_text() == "2"
    (val,) = curves.plot_validation_curve(fig.add_subplot(2, 1, 2), [0.5, 1.0], [40.0, 55.0], label="NDR")
    assert list(val.get_xdata()) == [0.5, 1.0] and list(val.get_ydata()) == [40.0, 55.0] and val.get_label() == "NDR"


def test_plots_take_ax_and_return_artists(fig):
    b, s, g = _grid()
    r = run_plan(b, s, g, "IQL", seed=0, keep_records=True, keep_q=True)
    ax = fig.subplots(2, 2)
    arts = curves.plot_training_curves(ax[0, 0], ax[0, 1], r.records.to_dict(), convergence_episode=r.convergence_episode)
    dashed = [a for a in arts if getattr(a, "get_linestyle", lambda: "")() == "--"]
    assert len(dashed) == 2 and dashed[0].get_xdata()[0] == r.convergence_episode
    coll = qtable.plot_qtable(ax[1, 0], r.q_table, b.shape, blocked=b)[0]
    assert len(coll.get_array()) == 4 * int((~b).sum())
    # the "up" triangle of cell (row 2, col 3) lies above its centre (smaller row = smaller y)
    tri = qtable.qtable_triangles(b.shape)[(2 * 20 + 3) * 4 + 0]
    assert tri[:, 1].max() == pytest.approx(2.0) and tri[:, 1].min() == pytest.approx(1.5)
    assert overlays.plot_method_paths(ax[1, 1], b, {"IQL": r.path, "QL": None}, s, g)
    assert overlays.plot_prediction(ax[1, 1], b, np.random.default_rng(1).random(b.shape), None)
    fig.savefig(io.BytesIO(), format="png")


def test_probability_overlay_has_a_colour_bar_and_the_legend_below(fig):
    ax = fig.add_subplot(1, 1, 1)
    obstacles = np.zeros((20, 30), bool)
    prob = np.linspace(0, 1, 600).reshape(20, 30)
    artists = viz_prediction.plot_probability_overlay(ax, obstacles, prob, kind="guideline", start=(1, 1), goal=(18, 28))
    bars = [a for a in artists if isinstance(a, Colorbar)]
    assert len(bars) == 1 and bars[0].cmap.name == style.GUIDELINE_CMAP
    legend = ax.get_legend()
    assert legend is not None and legend._loc == 9  # "upper center", anchored below the axes
    assert [t.get_text() for t in legend.get_texts()] == ["start", "goal"]


def test_label_comparison_colours(fig):
    ax = fig.add_subplot(1, 1, 1)
    obstacles = np.array([[True, False, False, False]])
    pred = np.array([[False, True, True, False]])
    label = np.array([[False, True, False, True]])
    (img,) = viz_prediction.plot_label_comparison(ax, obstacles, pred, label, title="F1")
    rgb = np.asarray(img.get_array())[0]
    assert rgb.tolist() == [[0.2] * 3, [0.2, 0.7, 0.2], [0.9, 0.2, 0.2], [0.2, 0.3, 0.9]]  # map, TP, FP, FN
    assert ax.get_title() == "F1" and not ax.axison


def test_one_method_palette():
    assert viz_plan.METHOD_COLORS is style.METHOD_COLORS and overlays.METHOD_COLORS is style.METHOD_COLORS
    assert style.method_color("A*") == style.ASTAR_COLOR == viz_plan.ASTAR_COLOR


def test_probability_opacity_grows_from_the_floor(fig):
    ax = fig.add_subplot(1, 1, 1)
    img = viz_plan.plot_probability(ax, np.array([[0.0, 0.2, 0.6, 1.0]]), (1.0, 0.0, 0.0), max_alpha=0.5, floor=0.2)
    rgba = np.asarray(img.get_array())
    assert rgba[0, :, 3].tolist() == pytest.approx([0.0, 0.0, 0.25, 0.5]) and rgba[0, 0, :3].tolist() == [1, 0, 0]


def test_plan_panel_layers_legend_and_collisions(fig):
    ax = fig.add_subplot(1, 1, 1)
    obstacles = np.zeros((40, 40), bool)
    blocked = np.zeros((4, 4), bool)
    route = SimpleNamespace(smoothed=True, pixels=[(5.0, 5.0), (35.0, 35.0)], final_collisions=[(0, (20.0, 20.0))])
    artists = viz_plan.plot_plan(ax, obstacles, blocked, (5, 5), (35, 35), path=[(0, 0), (0, 1), (1, 1)],
                                 astar_path=[(0, 0), (1, 0), (1, 1)], region=np.ones((40, 40)),
                                 guideline=np.zeros((40, 40)), label="IQL", title="run", route=route)
    labels = _labels(ax)
    assert labels[:4] == ["A* (2 moves)", "IQL (2 moves)", "IQL, smoothed on the map", "collision (1)"]
    assert labels[-4:] == ["obstacle", "blocked cell", "NDR region", "NDR guideline"]
    (cross,) = [a for a in artists if getattr(a, "get_label", lambda: "")() == "collision (1)"]
    assert cross.get_offsets().tolist() == [[20.0, 20.0]]
    assert ax.get_title() == "run" and ax.get_xlim() == (-0.5, 39.5)


def test_convergence_panel_means_and_non_converged_counts(fig):
    ax = fig.add_subplot(1, 1, 1)
    artists = viz_plan.plot_convergence(ax, {"QL": [100, 300, None], "IQL": [50, 50]}, title="steps")
    bars = [a for a in artists if hasattr(a, "patches")]
    assert [b.patches[0].get_height() for b in bars] == [200.0, 50.0]
    assert [t.get_text() for t in ax.get_xticklabels()] == ["QL\n1 not conv.", "IQL"]
    assert ax.get_title() == "steps"


def test_contact_sheet_draws_on_the_given_figure(fig):
    obstacles = np.zeros((10, 10), bool)
    item = SimpleNamespace(obstacles=obstacles, region=np.zeros_like(obstacles), guideline=np.eye(10, dtype=bool),
                           start=(0, 0), goal=(9, 9))
    axes = sheet.draw_sheet(fig, [("a", item), ("b", None), ("c", item)], title="sheet")
    assert len(axes) == 3 and fig.axes == axes and [ax.get_title() for ax in axes] == ["a", "b", "c"]
    assert [t.get_text() for t in axes[1].texts] == ["unusable at this grid"]
    assert fig.get_suptitle() == "sheet"
    assert sheet.sheet_grid(3) == (2, 2) and sheet.sheet_grid(10) == (3, 4) and sheet.sheet_grid(0) == (1, 1)
    other = Figure(figsize=(3.0, 2.0))
    assert sheet.contact_sheet([("a", item)], title="t", fig=other) is other
    assert len(other.axes) == 1 and tuple(other.get_size_inches()) == (3.0, 2.0)  # the caller's size stays
    own = sheet.contact_sheet([("a", item), ("b", item), ("c", item)])
    assert isinstance(own.canvas, FigureCanvasAgg) and tuple(own.get_size_inches()) == pytest.approx((4.4, 5.0))


@pytest.fixture(scope="module")
def report():
    """A two-method, two-seed plan on a small map with a wall (no NDR model needed)."""
    obstacles = np.zeros((60, 60), bool)
    obstacles[30, :45] = True
    return ndrql.solve(obstacles, (5, 5), (55, 5), methods=("QL", "IQL"), seeds=(0, 1), workers=1,
                       settings=PlanSettings.paper())


def test_plan_figure_draws_on_the_given_axes(fig, report):
    ax = fig.add_subplot(1, 2, 2)
    assert viz_plan.plan_figure(report, method="IQL", seed=1, ax=ax) is fig
    assert fig.axes == [ax] and ax.get_title().startswith("IQL seed 1")
    assert tuple(fig.get_size_inches()) == tuple(Figure().get_size_inches())  # not resized


def test_compare_figure_draws_on_the_given_figure(fig, report):
    assert viz_plan.compare_figure(report, fig=fig) is fig
    titles = [ax.get_title() for ax in fig.axes]
    assert len(titles) == 3 and titles[0].startswith("QL seed 0") and titles[1].startswith("IQL seed 0")
    assert titles[2] == "convergence steps, 2 seeds"


def test_plan_builders_make_their_own_figure_without_one(report):
    one, both = viz_plan.plan_figure(report, dpi=50), viz_plan.compare_figure(report, dpi=50)
    assert isinstance(one.canvas, FigureCanvasAgg) and len(one.axes) == 1 and one.dpi == 50
    assert isinstance(both.canvas, FigureCanvasAgg) and len(both.axes) == 3
    assert tuple(both.get_size_inches()) == pytest.approx((12.6, 5.6))  # 3 panels x 4.2 in, square map


def _reproduce_inputs():
    """One call of each viz.reproduce builder: (builder, arguments, axes it draws)."""
    b, s, g = _grid()
    r = run_plan(b, s, g, "IQL", seed=0, keep_records=True, keep_q=True)
    obstacles = np.kron(b, np.ones((4, 4), bool))
    prob = np.linspace(0, 1, b.size).reshape(b.shape)
    p = SimpleNamespace(blocked=b, start=s, goal=g, obstacles=obstacles, source_start=(1, 1), source_goal=(77, 1),
                        astar=r.astar_length, split="seen", index=3, category="maze", region=prob, guideline=prob)
    run = {"path": r.path, "records": r.records.to_dict(), "convergence_episode": r.convergence_episode}
    agg = {"seen/maze": {"QL": {"steps": {"median": 900}, "gap": {"mean": 0.2}},
                         "IQL": {"steps": {"median": 300}, "gap": {"mean": 0.1}}}}
    return [
        (viz_reproduce.curves_figure, (p, ["IQL"], ["IQL"], [run], [r], "curves"), 3),
        (viz_reproduce.maps_figure, ([p], ["MAP-1"], [(None, None)], [{"IQL": r.path}]), 2),
        (viz_reproduce.scale_figure, (agg, ["QL", "IQL"]), 2),
        (viz_reproduce.scale_distributions, ({"IQL": [{"convergence_steps": 300, "length_ratio": 1.1}]},), 2),
        (viz_reproduce.dynamic_figure, ([[("stage 1", p, run)]],), 2),
        (viz_reproduce.sizing_figure, ([("NDR", [{"train_hours": 0.5, "val_region_f1": 40.0, "val_guideline_f1": 30.0}])],), 2),
    ]


@pytest.mark.parametrize("case", range(6), ids=["curves", "maps", "scale", "scale_distributions", "dynamic", "sizing"])
def test_reproduce_builders_draw_on_the_given_figure(fig, case):
    builder, args, n_axes = _reproduce_inputs()[case]
    assert builder(*args, fig=fig) is fig
    assert len(fig.axes) == n_axes and tuple(fig.get_size_inches()) == tuple(Figure().get_size_inches())
    fig.savefig(io.BytesIO(), format="png")
    own = builder(*args)
    assert own is not fig and isinstance(own.canvas, FigureCanvasAgg) and len(own.axes) == n_axes


def test_legend_below_and_colour_bar(fig):
    ax = fig.add_subplot(1, 1, 1)
    image = ax.imshow(np.zeros((2, 2)), vmin=0, vmax=1)
    ax.plot([0, 1], [0, 1], label="path")
    legend = style.legend_below(ax)
    assert legend is ax.get_legend() and _labels(ax) == ["path"] and not legend.get_frame_on()
    bar = style.probability_colorbar(ax, image, "region probability")
    assert isinstance(bar, Colorbar) and bar.ax.get_ylabel() == "region probability" and len(fig.axes) == 2


def test_scale_figures_draw_the_oracle_row_hatched_and_dashed_in_its_methods_colour(fig):
    oracle = "NDR-QL (oracle priors)"
    agg = {"seen/maze": {"NDR-QL": {"steps": {"median": 300}, "gap": {"mean": 0.1}},
                         oracle: {"steps": {"median": 200}, "gap": {"mean": 0.05}}}}
    ax1, _ = viz_reproduce.scale_figure(agg, ["NDR-QL", oracle], fig=fig).axes
    model_bar, oracle_bar = ax1.patches
    assert _labels(ax1) == ["NDR-QL", oracle]
    assert oracle_bar.get_hatch() == "///" and model_bar.get_hatch() is None
    assert oracle_bar.get_edgecolor() == model_bar.get_facecolor() == to_rgba(style.METHOD_COLORS["NDR-QL"])
    assert (model_bar.get_height(), oracle_bar.get_height()) == (300, 200)
    other = Figure()
    runs = [{"convergence_steps": 300, "length_ratio": 1.1}]
    steps = viz_reproduce.scale_distributions({"NDR-QL": runs, oracle: runs}, fig=other).axes[0]
    assert [line.get_linestyle() for line in steps.lines] == ["-", "--"]
    assert style.oracle_base(oracle) == "NDR-QL" and style.oracle_base("NDR-QL") is None
