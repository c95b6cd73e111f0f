"""The package's layering, in one place: who may import whom.

    errors, _layers, _lazy, version -> io, limits, workers -> maps -> planning -> synth -> dataset -> model -> training
    -> pipeline -> env -> viz -> tuning, experiments -> api -> cli -> ndrql, __main__

A module may import modules of its own package and of any package on an earlier layer, never one on
its own layer (no sideways imports) or a later one, even inside a function. ``tools/import_graph.py``
draws the graph and lists every import that breaks the rule; ``tests/test_architecture.py`` fails on
one. ``ndrql`` is the root package (``ndrql/__init__.py``), ``__main__`` is ``python -m ndrql``.

``planning`` sits right above ``maps``: the planners take arrays (a planning grid, start, goal and
the model's predictions on the grid) and cannot reach the network; ``pipeline`` is where a map,
the model and the planners meet.
"""

from __future__ import annotations

LAYERS: tuple[tuple[str, ...], ...] = (
    ("errors", "_layers", "_lazy", "version"),
    ("io", "limits", "workers"),
    ("maps",),
    ("planning",),
    ("synth",),
    ("dataset",),
    ("model",),
    ("training",),
    ("pipeline",),
    ("env",),
    ("viz",),
    ("tuning", "experiments"),
    ("api",),
    ("cli",),
    ("ndrql", "__main__"),
)
"""Packages (first name under ``ndrql``) from the bottom layer to the top."""

LAZY_MARK = "# lazy:"
"""An ``ndrql`` import inside a function carries this comment with its reason (start-up time)."""

MAX_MODULE_LINES = 400
"""Longest module, in lines."""


def layer_of(package: str) -> int:
    """Index of ``package``'s layer in :data:`LAYERS`; ``KeyError`` for a package not listed."""
    for i, group in enumerate(LAYERS):
        if package in group:
            return i
    raise KeyError(f"package {package!r} is not in ndrql._layers.LAYERS; add it to a layer")


def layer_line() -> str:
    """The layering as one line (for docs and the tool's output)."""
    return " -> ".join(", ".join(group) for group in LAYERS)
