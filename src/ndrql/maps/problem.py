"""A map with a start and a goal: the shape every planning problem of ndrql has.

:class:`MapProblem` holds the three things every problem, sample and model input share; the
types that carry more are built on it: a generated sample adds its path
(:class:`ndrql.synth.generate.RawSample`), a model input its labels
(:class:`ndrql.dataset.render.Rendered`), an environment's problem keeps one as its source map
(:class:`ndrql.env.sources.EnvProblem`), a command's problem the map as read with its resolution and
source (:class:`ndrql.cli.common.Problem`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ndrql.maps.grid import Cell


@dataclass(frozen=True)
class MapProblem:
    """A map and two points on it, ``(row, col)`` in the map's own pixels."""

    obstacles: np.ndarray
    """(H, W) bool, ``True`` = obstacle."""
    start: Cell
    """Start pixel (row, col)."""
    goal: Cell
    """Goal pixel (row, col)."""
