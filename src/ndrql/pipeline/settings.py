"""How a map becomes a planning problem (:class:`PlanSettings`): grid rule, size, robot radius, smoothing, limits."""

from __future__ import annotations

from dataclasses import dataclass

from ndrql.errors import NdrqlError, brief
from ndrql.limits import MAX_GRID_SIZE, MIN_GRID_SIZE, check_fields, check_threads
from ndrql.maps.grid import PLANNING_SIZE
from ndrql.maps.readers import MAX_MAP_PIXELS
from ndrql.maps.safe import DEFAULT_MAX_SIZE
from ndrql.model.predict import BACKENDS
from ndrql.model.symmetry import DEFAULT_COUNT as DEFAULT_SYMMETRIES, check_count as check_symmetries
from ndrql.planning.methods import get_method

#: Seconds :attr:`PlanSettings.predict_budget` gives the prediction by default, counted once the model is loaded
#: (a first load that exports a checkpoint or imports torch is a one-off cost, not the map's): the forward pass at
#: 256-600 cells takes 0.3-0.6 s here on an idle core, about 2 s with both cores busy (docs/results.md).
DEFAULT_PREDICT_BUDGET = 2.0
#: Largest :attr:`PlanSettings.predict_budget` (an hour): beyond it "no limit" (None) says what is meant.
MAX_PREDICT_BUDGET = 3600.0

#: Planning-grid rules: ``safe`` (square cells, a cell blocked when any pixel is an obstacle; the
#: default on a user's map) and ``area`` (the paper's rule: area average, blocked at >= 0.5).
GRID_RULES: tuple[str, ...] = ("safe", "area")
#: Above this many cells on the longer side ``plan`` warns that Q-learning may take minutes.
SLOW_SIZE = 256


#: The numeric fields of :class:`PlanSettings`, each bounded in :data:`ndrql.limits.BOUNDS`.
NUMERIC_SETTINGS = ("size", "robot_radius", "tolerance", "max_map_pixels", "max_size", "threads", "symmetries",
                    "predict_budget")


@dataclass(frozen=True)
class PlanSettings:
    """How a map becomes a planning problem, and the limits that guard it.

    A field left unset (``None``, fallback ``auto``) is decided by
    :func:`~ndrql.pipeline.request.build_request` from the input: on a user's own map the safe grid,
    ``size="auto"``, smoothing on and the IQL-BFS fallback for one method; on a dataset sample the paper's
    setting, :meth:`paper` (used by the reproduction commands).
    """

    grid: str | None = None
    """Planning-grid rule: safe (square cells, blocked if any pixel is an obstacle) or area (the paper's >= 0.5 rule); default: safe on a user's map, area on a dataset sample."""
    size: int | str | None = None
    """Cells on the map's longer side, or auto (the coarsest safe grid that keeps the route); default: auto for safe, 50 for area."""
    robot_radius: float = 0.0
    """Robot radius: obstacles are inflated by it before planning (metres on maps with a resolution, else pixels)."""
    smooth: bool | None = None
    """Shortcut the learned path by line of sight on the full map (default: on for a user's map, off for a dataset sample)."""
    fallback: str | None = "auto"
    """Method to plan with instead of an NDR method when the model's prediction is uninformative (None: keep it; default auto: IQL-BFS, the exact distance, for one method on a user's map, none on a dataset sample or with several methods)."""
    tolerance: float = 0.08
    """size auto: how much longer than the map's own shortest route the grid's route may be."""
    max_map_pixels: int = MAX_MAP_PIXELS
    """Largest map accepted, in pixels; larger maps are refused (crop or downscale them first)."""
    max_size: int = DEFAULT_MAX_SIZE
    """Largest planning grid (cells on the longer side); Q-learning's episode cap is 4 x cells, so big grids take long."""
    threads: int = 1
    """Threads for the model's forward pass (1: about as fast as 2 for one map, and much faster on a busy machine)."""
    backend: str = "auto"
    """Model inference backend: auto (ONNX Runtime when installed, else torch), onnx or torch."""
    learned_distance: bool = True
    """Eq. 6's distance term from the model's predicted distance to the goal when the model has one (False: the paper's straight line)."""
    symmetries: int = DEFAULT_SYMMETRIES
    """Grid-mode models: average the prediction over this many orientations of the grid (1, 2, 4 or 8; one forward pass each, in one batch)."""
    predict_budget: float | None = DEFAULT_PREDICT_BUDGET
    """Seconds the prediction may take once the model is loaded; past them the plan falls back and says so (None: no limit)."""

    def __post_init__(self) -> None:
        check_fields(self, tuple(n for n in NUMERIC_SETTINGS if n != "size"), strict=True)  # ndrql.limits.BOUNDS
        for name in ("grid", "fallback", "backend"):
            if not isinstance(getattr(self, name), (str, type(None))):
                raise NdrqlError(f"{name} must be a name (text), got {brief(getattr(self, name))}")
        if self.grid is not None and self.grid not in GRID_RULES:
            raise NdrqlError(f"unknown planning grid rule {self.grid!r}; valid: {', '.join(GRID_RULES)}")
        size = self.size
        if isinstance(size, str):
            if size.strip().lower() != "auto":
                try:
                    size = int(size)
                except ValueError:
                    raise NdrqlError(f"--size must be an integer in {MIN_GRID_SIZE}..{MAX_GRID_SIZE:,} or auto, "
                                     f"got {brief(self.size)}") from None
            else:
                size = "auto"
            object.__setattr__(self, "size", size)
        if size == "auto" and self.grid == "area":
            raise NdrqlError("size auto needs the safe grid (--grid safe); the area rule takes a size such as 50")
        if isinstance(size, bool) or (size not in (None, "auto") and not isinstance(size, int)):
            raise NdrqlError(f"--size must be an integer in {MIN_GRID_SIZE}..{MAX_GRID_SIZE:,} or auto, got {brief(self.size)}")
        if isinstance(size, int):
            if not MIN_GRID_SIZE <= size <= MAX_GRID_SIZE:
                raise NdrqlError(f"--size must be an integer in {MIN_GRID_SIZE}..{MAX_GRID_SIZE:,} (planning-grid cells on "
                                 f"the map's longer side) or auto, got {size}")
            if size > self.max_size:
                raise NdrqlError(f"the planning grid size {size} is larger than the limit {self.max_size} "
                                 f"(Q-learning's episode cap grows with the cells; raise it with --max-size, up to "
                                 f"{MAX_GRID_SIZE})")
        if not self.robot_radius >= 0 or self.robot_radius == float("inf"):
            raise NdrqlError(f"the robot radius must be a number >= 0, got {self.robot_radius}")
        if not 0 <= self.tolerance < 10:
            raise NdrqlError(f"the size auto tolerance must be in [0, 10), got {self.tolerance}")
        if self.max_map_pixels < 1:
            raise NdrqlError(f"max_map_pixels must be positive, got {self.max_map_pixels}")
        if isinstance(self.fallback, str) and self.fallback.strip().lower() == "none":
            object.__setattr__(self, "fallback", None)
        if self.fallback is not None and self.fallback != "auto":
            fb = get_method(self.fallback)
            if fb.needs_ndr:
                raise NdrqlError(f"the fallback {fb.name} uses the model itself; give a method without it (QL, IQL, ...)")
            object.__setattr__(self, "fallback", fb.name)

        if not MIN_GRID_SIZE <= self.max_size <= MAX_GRID_SIZE:
            raise NdrqlError(f"the grid size limit must be in {MIN_GRID_SIZE}..{MAX_GRID_SIZE}, got {self.max_size}")

        if self.backend not in BACKENDS:
            raise NdrqlError(f"unknown inference backend {self.backend!r}; valid: {', '.join(BACKENDS)}")
        check_symmetries(self.symmetries, NdrqlError)
        b = self.predict_budget
        if b is not None and (isinstance(b, bool) or not isinstance(b, (int, float)) or not 0 < b <= MAX_PREDICT_BUDGET):
            raise NdrqlError(f"the prediction budget must be seconds in (0, {MAX_PREDICT_BUDGET:g}] or None (no limit), "
                             f"got {brief(b)}")
        check_threads(self.threads, "threads (--threads)")

    @classmethod
    def paper(cls, **overrides) -> "PlanSettings":
        """The paper's setting (docs/method.md): area rule, 50 cells, no smoothing, no fallback; used on the dataset."""
        kw: dict = {"grid": "area", "size": PLANNING_SIZE, "smooth": False, "fallback": None}
        kw.update(overrides)
        return cls(**kw)

    @property
    def grid_size(self) -> int | str:
        """The size in effect: the given one, else auto (safe) or 50 (area)."""
        if self.size is None:
            return PLANNING_SIZE if self.grid == "area" else "auto"
        return self.size

    @property
    def smoothing(self) -> bool:
        """Whether the learned path is shortcut on the full map (default: on for safe, off for area)."""
        return (self.grid != "area") if self.smooth is None else bool(self.smooth)
