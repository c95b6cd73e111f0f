"""A map with a start and a goal: the shape every planning problem of ndrql has.

:class:`MapProblem` holds the three things every problem, sample and model input share; the
types that carry more are built on it: a map as read (:class:`GridMapProblem`: the
:class:`~ndrql.maps.grid.GridMap` with its resolution and origin, and where it came from; a command's
problem and the bundled sample map), a generated sample adds its path
(:class:`ndrql.synth.generate.RawSample`), a model input its labels
(:class:`ndrql.dataset.render.Rendered`), a case of the ceiling study its safe grid
(:class:`ndrql.experiments.ceiling.GridCase`). A problem whose ``start`` and ``goal`` are planning-grid
cells keeps a :class:`MapProblem` as its source map instead: an environment's problem
(:class:`ndrql.env.sources.EnvProblem`) and an experiment's (:class:`ndrql.pipeline.samples.Problem`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ndrql.maps.grid import Cell, GridMap


@dataclass(frozen=True)
class MapProblem:
    """A map and two points on it, ``(row, col)`` in the map's own pixels."""

    obstacles: np.ndarray
    """(H, W) bool, ``True`` = obstacle."""
    start: Cell
    """Start pixel (row, col)."""
    goal: Cell
    """Goal pixel (row, col)."""


@dataclass(frozen=True)
class GridMapProblem(MapProblem):
    """A :class:`MapProblem` on a map as read: ``obstacles`` is ``grid_map``'s, which also keeps the
    resolution, origin and source; build it with :meth:`of`."""

    grid_map: GridMap
    """The map as read (``obstacles`` is its obstacle array)."""
    info: dict[str, Any] = field(default_factory=dict)
    """Where it came from: map file, dataset sample (split, index, category) or the bundled map's source."""

    @classmethod
    def of(cls, grid_map: GridMap, start: Cell, goal: Cell, info: dict[str, Any] | None = None) -> "GridMapProblem":
        """The problem of ``grid_map`` from ``start`` to ``goal`` (source pixels, row-col)."""
        return cls(grid_map.obstacles, start, goal, grid_map, {} if info is None else info)
