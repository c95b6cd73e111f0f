"""Where the environments' planning problems come from: a map file, a map generator or the dataset.

A problem is a planning grid (the map downscaled, :mod:`ndrql.maps.grid` or :mod:`ndrql.maps.safe`)
with a start and a goal cell that are free and 4-connected, plus the source map in pixels (for the
NDR model's prior channels). Sources draw every random choice from the generator they are given:
an environment passes its own ``self.np_random``, so ``reset(seed=s)`` fixes the map too.

- :func:`map_problem`: a map (file path in any format :func:`ndrql.maps.load_map` reads, a
  :class:`~ndrql.maps.grid.GridMap` or a bool array) and a start and goal in map pixels;
- :func:`grid_problem`: a planning grid given directly, start and goal in cells;
- :class:`GeneratorSource`: maps of the procedural families (:mod:`ndrql.synth.families`) with
  endpoints drawn like the dataset's (:func:`ndrql.synth.endpoints.sample_endpoints`);
- :class:`DatasetSource`: samples of the path-planning dataset (its own start and goal), read through
  the decoded cache (:func:`ndrql.dataset.cache.load_split`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ndrql.dataset.cache import load_split
from ndrql.dataset.layout import check_root, normalize_split
from ndrql.errors import NdrqlError, NoPathError, PointError
from ndrql.limits import MAX_GRID_SIZE
from ndrql.maps.grid import (MODEL_SIDE, PLANNING_SIZE, GridMap, bfs_distances, nearest_free_bfs, planning_grid,
                             point_to_cell)
from ndrql.maps.problem import MapProblem
from ndrql.pipeline.problem import build_grid, read_map as read_any_map
from ndrql.pipeline.request import request_settings
from ndrql.pipeline.settings import GRID_RULES
from ndrql.synth.endpoints import sample_endpoints

Cell = tuple[int, int]


#: Draws a source makes before giving up on a map whose endpoints do not connect.
MAX_DRAWS = 100


@dataclass(frozen=True)
class EnvProblem:
    """A planning problem for an environment: grid, free and 4-connected start and goal cells."""

    blocked: np.ndarray
    """Planning grid, bool ``(h, w)``, ``True`` = blocked."""
    start: Cell
    """Start cell ``(row, col)``."""
    goal: Cell
    """Goal cell ``(row, col)``."""
    source: MapProblem | None = None
    """The map in pixels with start and goal in its pixels (for the NDR model's prior channels);
    ``None`` when the grid was given directly."""
    name: str = ""
    """Where it came from: a file, ``family:maze`` or ``dataset:seen:12``."""
    astar_length: int = field(default=-1)
    """Moves of a shortest 4-connected path from start to goal on the grid."""
    grid_size: int | None = None
    """Cells on the map's longer side (the size ``auto`` chose, on the safe grid); ``None`` when not recorded."""


def _snap(blocked: np.ndarray, cell: Cell, name: str) -> Cell:
    free = nearest_free_bfs(blocked, cell)
    if free != cell:
        warnings.warn(f"{name} falls in blocked planning cell {cell}; moved to the nearest free cell {free}",
                      UserWarning, stacklevel=3)
    return free


def _checked(blocked: np.ndarray, start: Cell, goal: Cell, **extra: Any) -> EnvProblem:
    """An :class:`EnvProblem` after checking that ``start`` and ``goal`` differ and are 4-connected."""
    if start == goal:
        raise PointError(f"start and goal fall in the same planning cell {start}; choose points further apart")
    dist = bfs_distances(blocked, start)
    if dist[goal] < 0:
        raise NoPathError(f"start {start} and goal {goal} are not 4-connected on the "
                          f"{blocked.shape[0]}x{blocked.shape[1]} planning grid")
    return EnvProblem(blocked=blocked, start=start, goal=goal, astar_length=int(dist[goal]), **extra)


def _cell(point: Sequence[int], name: str) -> Cell:
    try:
        r, c = (int(v) for v in point)
    except (TypeError, ValueError):
        raise PointError(f"{name} must be (row, col), got {point!r}") from None
    return (r, c)


def grid_problem(blocked: np.ndarray, start: Sequence[int], goal: Sequence[int], name: str = "grid") -> EnvProblem:
    """A problem on a planning grid given directly (``True`` = blocked); ``start``/``goal`` are free cells."""
    blocked = np.array(blocked, dtype=bool)
    if blocked.ndim != 2 or blocked.size == 0:
        raise NdrqlError(f"grid must be a non-empty 2-D bool array, got shape {blocked.shape}")
    h, w = blocked.shape
    cells = []
    for label, point in (("start", start), ("goal", goal)):
        cell = _cell(point, label)
        if not (0 <= cell[0] < h and 0 <= cell[1] < w) or blocked[cell]:
            raise PointError(f"{label} {cell} must be a free cell of the {h}x{w} grid")
        cells.append(cell)
    return _checked(blocked, cells[0], cells[1], name=name)


def read_map(source: str | Path | GridMap | np.ndarray) -> tuple[np.ndarray, str]:
    """Obstacles (bool ``(H, W)``) and a name for a map file, a :class:`GridMap` or an array (non-zero = obstacle)."""
    grid_map = read_any_map(source if isinstance(source, (str, Path, GridMap)) else np.asarray(source))
    return grid_map.obstacles, str(source) if isinstance(source, (str, Path)) else (grid_map.source or "map")


def map_problem(
    source: str | Path | GridMap | np.ndarray,
    start: Sequence[int],
    goal: Sequence[int],
    size: int | str = PLANNING_SIZE,
    rule: str = "area",
    obstacles: np.ndarray | None = None,
    name: str | None = None,
    robot_radius: float = 0.0,
) -> EnvProblem:
    """A problem on map ``source`` from ``start`` to ``goal`` (map pixels, row-col).

    The map becomes a planning grid of ``size`` cells on its longer side by ``rule``; a point whose
    cell is blocked moves to the nearest free cell with a warning; :class:`PointError` for a point
    off the map or on an obstacle, :class:`NoPathError` when the cells are not 4-connected.
    ``obstacles`` skips reading ``source`` again (it is then only the name). The ``safe`` rule is
    ``ndrql plan``'s own grid (:func:`ndrql.pipeline.problem.build_grid`: ``size`` may be ``"auto"``,
    obstacles inflated by ``robot_radius``, metres on maps with a resolution); :attr:`EnvProblem.grid_size`
    says which size it took.
    """
    if rule == "safe":  # the map as read (a ROS map keeps its resolution: robot_radius in metres)
        grid_map = read_any_map(source) if obstacles is None else GridMap(obstacles, source=str(source))
        shown = str(source) if isinstance(source, (str, Path)) else (grid_map.source or "map")
        return _plan_grid_problem(grid_map, start, goal, size, robot_radius, name or shown)
    if obstacles is None:
        obstacles, shown = read_map(source)
    else:
        shown = str(source)
    if robot_radius:
        raise NdrqlError("robot_radius needs the safe grid (grid_rule='safe'): the paper's area grid does not inflate")
    h, w = obstacles.shape
    if rule != "area":
        raise NdrqlError(f"unknown planning-grid rule {rule!r}; valid: {', '.join(GRID_RULES)}")
    blocked = planning_grid(obstacles, int(size))
    cells, points = [], []
    for label, point in (("start", start), ("goal", goal)):
        p = _cell(point, label)
        if not (0 <= p[0] < h and 0 <= p[1] < w):
            raise PointError(f"{label} {p[0]},{p[1]} is off the map (rows 0..{h - 1}, cols 0..{w - 1})")
        if obstacles[p]:
            raise PointError(f"{label} {p[0]},{p[1]} is on an obstacle of the map")
        cells.append(_snap(blocked, point_to_cell(p, (h, w), blocked.shape), f"{label} {p}"))
        points.append(p)
    return _checked(blocked, cells[0], cells[1], source=MapProblem(obstacles, points[0], points[1]), name=name or shown)


def _plan_grid_problem(grid_map: GridMap, start: Sequence[int], goal: Sequence[int], size: int | str,
                       robot_radius: float, name: str) -> EnvProblem:
    """A problem on the safe grid ``ndrql plan`` builds for this map and these points."""
    obstacles = grid_map.obstacles
    points = []
    for label, point in (("start", start), ("goal", goal)):
        p = _cell(point, label)
        h, w = obstacles.shape
        if not (0 <= p[0] < h and 0 <= p[1] < w):
            raise PointError(f"{label} {p[0]},{p[1]} is off the map (rows 0..{h - 1}, cols 0..{w - 1})")
        if obstacles[p]:
            raise PointError(f"{label} {p[0]},{p[1]} is on an obstacle of the map")
        points.append(p)
    settings = request_settings(grid="safe", size=size, robot_radius=robot_radius, max_size=MAX_GRID_SIZE)
    pg, setup = build_grid(grid_map, points[0], points[1], settings)
    return _checked(pg.blocked, pg.start, pg.goal, source=MapProblem(obstacles, points[0], points[1]), name=name,
                    grid_size=setup.size)


def _quiet_problem(obstacles: np.ndarray, start: Cell, goal: Cell, size: int, rule: str, name: str) -> EnvProblem | None:
    """:func:`map_problem` for a drawn map, ``None`` (no warning) when its endpoints do not make a problem."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        try:
            return map_problem(name, start, goal, size, rule, obstacles=obstacles)
        except (PointError, NoPathError):
            return None


@dataclass(frozen=True)
class GeneratorSource:
    """Maps of the procedural families, a family drawn uniformly per map."""

    families: tuple[str, ...] | None = None
    """Family names (:func:`ndrql.synth.families.family_names`); ``None`` = all."""
    map_px: int = 64
    """Side of the generated map in pixels (at least 16)."""
    size: int = 16
    """Planning-grid cells on a side."""
    rule: str = "area"
    """Planning-grid rule (:data:`GRID_RULES`)."""
    min_dist_frac: float = 0.5
    """Start-goal distance, at least this fraction of the map side (the dataset uses 0.75)."""

    def __post_init__(self) -> None:
        from ndrql.synth.families import MIN_SIDE, family_names  # lazy: loads scipy

        names = family_names()
        chosen = names if self.families is None else tuple(self.families)
        bad = [f for f in chosen if f not in names]
        if bad or not chosen:
            raise NdrqlError(f"unknown map family {', '.join(map(repr, bad)) or '(none given)'}; valid: {', '.join(names)}")
        object.__setattr__(self, "families", chosen)
        if int(self.map_px) < MIN_SIDE:
            raise NdrqlError(f"map_px must be at least {MIN_SIDE}, got {self.map_px}")
        if not 2 <= int(self.size) <= int(self.map_px):
            raise NdrqlError(f"size must be between 2 and map_px ({self.map_px}), got {self.size}")
        if self.rule not in GRID_RULES:
            raise NdrqlError(f"unknown planning-grid rule {self.rule!r}; valid: {', '.join(GRID_RULES)}")

    def draw(self, rng: np.random.Generator) -> EnvProblem:
        """A new map, start and goal, every choice from ``rng``."""
        from ndrql.synth.families import generate_map  # lazy: loads scipy

        for _ in range(MAX_DRAWS):
            family = self.families[int(rng.integers(len(self.families)))]  # type: ignore[index]
            obstacles = generate_map(family, rng, int(self.map_px), int(self.map_px))
            ends = sample_endpoints(rng, obstacles, min_dist_frac=self.min_dist_frac)
            if ends is None:
                continue
            found = _quiet_problem(obstacles, ends[0], ends[1], int(self.size), self.rule, f"family:{family}")
            if found is not None:
                return found
        raise NoPathError(f"no connected start and goal in {MAX_DRAWS} maps of {', '.join(self.families)} "
                          f"at {self.size} cells; use a larger size")


@dataclass(frozen=True)
class DatasetSource:
    """Samples of the path-planning dataset, drawn uniformly, with their own start and goal."""

    root: str | Path
    """Dataset root in its original layout (the folder holding ``TRAIN`` and ``TEST``)."""
    split: str = "train"
    """``train``, ``seen`` or ``unseen``."""
    size: int = PLANNING_SIZE
    """Planning-grid cells on a side (the paper: 50)."""
    rule: str = "area"
    """Planning-grid rule (:data:`GRID_RULES`)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "split", normalize_split(self.split))
        check_root(self.root)
        if not 2 <= int(self.size) <= MODEL_SIDE:
            raise NdrqlError(f"size must be between 2 and {MODEL_SIDE}, got {self.size}")
        if self.rule not in GRID_RULES:
            raise NdrqlError(f"unknown planning-grid rule {self.rule!r}; valid: {', '.join(GRID_RULES)}")

    def arrays(self):
        """The decoded split (built into the cache on first use, then loaded from it)."""
        return _load_split(str(Path(self.root).resolve()), self.split)

    def draw(self, rng: np.random.Generator) -> EnvProblem:
        """A random sample whose start and goal connect on the planning grid."""
        data = self.arrays()
        for _ in range(MAX_DRAWS):
            i = int(rng.integers(len(data)))
            sr, sc, gr, gc = (int(v) for v in data.points[i])
            found = _quiet_problem(data.obstacles(i), (sr, sc), (gr, gc), int(self.size), self.rule,
                                   f"dataset:{self.split}:{i}")
            if found is not None:
                return found
        raise NoPathError(f"no sample of {self.split} connects at {self.size} cells in {MAX_DRAWS} draws")


@lru_cache(maxsize=4)
def _load_split(root: str, split: str) -> Any:
    """A decoded split, loaded once per process (read-only arrays; loading one takes about a second)."""
    return load_split(root, split, progress=False)
