"""The one figure style of ``plan``, ``astar``, ``predict`` and ``demo``: colours, markers, legend, colour bars.

Every figure of the map uses the same colours for the same things: obstacles black, blocked
planning cells grey, the NDR region green, the guideline orange, the A* path blue and dashed, start
a green circle, goal a blue star, each method its own colour. Legends sit below the map (never on
it) and probability maps carry a colour bar. Figures are written at :data:`DEFAULT_DPI` unless the
command's ``--dpi`` says otherwise.
"""

from __future__ import annotations

from typing import Any, Sequence

from ndrql.synth.oracle import ORACLE_NAME

#: Dots per inch of the CLI's figures (``--dpi`` overrides it).
DEFAULT_DPI = 110

OBSTACLE_COLOR = "black"
BLOCKED_COLOR = "0.55"
BLOCKED_ALPHA = 0.25
ASTAR_COLOR = "tab:blue"
START_COLOR = "tab:green"
GOAL_COLOR = "tab:blue"
COLLISION_COLOR = "red"
REGION_RGB = (0.15, 0.65, 0.25)
GUIDELINE_RGB = (1.0, 0.55, 0.0)
#: Colour maps of probability images (0 white, 1 the overlay's colour).
REGION_CMAP = "Greens"
GUIDELINE_CMAP = "Oranges"

#: One colour per method, stable across figures.
METHOD_COLORS: dict[str, str] = {
    "QL": "tab:gray", "O-QL": "tab:orange", "IQL": "tab:purple", "NDR-QL": "tab:red",
    "D-C": "tab:brown", "N-C": "tab:pink", "D-Q": "tab:olive", "N-Q": "tab:cyan", "A*": ASTAR_COLOR,
}


def method_color(name: str, i: int = 0) -> str:
    """The colour of a method (a fallback cycle for names not in :data:`METHOD_COLORS`); a row with the
    oracle's priors (``"NDR-QL (oracle priors)"``) takes its method's colour."""
    cycle = ("tab:green", "tab:pink", "tab:olive", "tab:cyan", "tab:brown")
    return METHOD_COLORS.get(oracle_base(name) or name, cycle[i % len(cycle)])


def oracle_base(name: str) -> str | None:
    """The method of a row named ``"<method> (oracle priors)"``, else ``None``."""
    suffix = f" ({ORACLE_NAME})"
    return name[: -len(suffix)] if name.endswith(suffix) else None


def row_style(name: str, i: int = 0) -> dict[str, Any]:
    """Colour, and for an oracle row a hatch and a dashed line, of a method row in a bar or line plot.

    ``bar`` keys go to ``Axes.bar``, ``line`` keys to ``Axes.plot``/``step``/``hist``."""
    color = method_color(name, i)
    if oracle_base(name) is None:
        return {"bar": {"color": color}, "line": {"color": color}}
    return {"bar": {"facecolor": "white", "edgecolor": color, "hatch": "///"}, "line": {"color": color, "linestyle": "--"}}


def legend_below(ax: Any, handles: Sequence[Any] | None = None, ncol: int = 3) -> Any:
    """A legend under the axes (outside the map), small and frameless; returns it."""
    if handles is None:
        handles, _ = ax.get_legend_handles_labels()
    return ax.legend(handles=list(handles), loc="upper center", bbox_to_anchor=(0.5, -0.02), ncol=ncol,
                     fontsize=7, frameon=False)


def probability_colorbar(ax: Any, image: Any, label: str) -> Any:
    """A colour bar for a probability image (0..1) beside ``ax``; returns it."""
    bar = ax.figure.colorbar(image, ax=ax, fraction=0.046, pad=0.02)
    bar.set_label(label, fontsize=8)
    bar.ax.tick_params(labelsize=7)
    return bar
