"""Prediction API: region and guideline probabilities for any map, with the shipped model by default.

What the model sees follows its input mode. ``map`` models (the paper's): maps that are not 201x201
are brought to the model's scale first and the probabilities mapped back to the map's own size
(:func:`ndrql.dataset.render.to_model_input`, :func:`~ndrql.dataset.render.from_model_output`).
``grid`` models (the shipped default, ``general``): the safe planning grid at 4 px per cell, as
``ndrql plan`` builds it (:meth:`Predictor.predict`), through the view the model was trained under
(:class:`ndrql.dataset.views.GridView`, its config's ``view``; ``native`` when absent): under
``coarse:128`` a grid above 128 cells is merged into at most 128 cells before the model sees it, and
:meth:`Predictor.predict_cells` brings every output back per planning cell.
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ndrql.dataset.encodings import encode_input, has_unknown
from ndrql.dataset.render import DISTANCE_UNIT, PX_PER_CELL, cells_to_map, from_model_output, manhattan_pixels, to_model_input
from ndrql.dataset.views import GridView, ViewInput, view_cells, view_distance_cells, view_input
from ndrql.errors import TRAIN_INSTALL, CheckpointError, MissingDependency, NdrqlError, PointError, require_torch
from ndrql.limits import check_threads
from ndrql.maps.safe import DEFAULT_MAX_SIZE, cell_size_px
from ndrql.maps import sizing  # sizing.safe_grid, read at each call: the one builder (tests count its calls)
from ndrql.maps.sizing import choose_size, full_route
from ndrql.model.companion import check_companion, companion_path, missing_companion, weights_digest
from ndrql.model.export import cached_export
from ndrql.model.onnx_backend import can_export, onnx_available, onnx_runner
from ndrql.model.symmetry import DEFAULT_COUNT, averaged, check_count
from ndrql.model.torch_runner import TorchRunner
from ndrql.model.weights import resolve_weights

Point = tuple[int, int]


@dataclass(frozen=True)
class Prediction:
    """Model output at the map's resolution, probabilities in [0, 1]."""

    region: np.ndarray
    guideline: np.ndarray | None
    grid: GridPrediction | None = None
    """What a grid-mode model predicted on the safe planning grid it saw; ``None`` for map-mode models."""


@dataclass(frozen=True)
class GridPrediction:
    """A grid-mode model's prediction on the safe planning grid it saw (:meth:`Predictor.predict`)."""

    size: int
    """Cells on the map's longer side (``ndrql plan --size``)."""
    blocked: np.ndarray
    """The safe grid, bool ``(h, w)`` (:func:`~ndrql.maps.safe.conservative_grid` of the map)."""
    start: Point
    """Start cell, placed as ``ndrql plan`` places it (:func:`~ndrql.maps.sizing.place_point`)."""
    goal: Point
    """Goal cell."""
    region: np.ndarray
    """Region per cell, float64 ``(h, w)``: the mean of the pixels of the cell the model saw (its 4x4
    pixels under the ``native`` view; its merged cell's under ``coarse``, :meth:`Predictor.predict_cells`)."""
    guideline: np.ndarray | None
    """Guideline per cell, as ``region``."""
    distance: np.ndarray | None = None
    """Predicted distance to the goal through free space per cell, in cells (the mean of the cell's
    pixels); ``None`` for a model without a distance head."""


@dataclass(frozen=True)
class CellPrediction:
    """A grid-mode model's outputs per planning cell and what it saw (:meth:`Predictor.predict_view`)."""

    region: np.ndarray
    """Region per planning cell, float64 ``(h, w)`` (:func:`~ndrql.dataset.views.view_cells`)."""
    guideline: np.ndarray | None
    """Guideline per planning cell, as ``region``; ``None`` for a model without a guideline decoder."""
    distance: np.ndarray | None
    """Goal distance per planning cell, in planning cells (:func:`~ndrql.dataset.views.view_distance_cells`);
    ``None`` for a model without a distance head."""
    seen: ViewInput
    """The model's input: the image, start and goal pixels, pixels per seen cell and the merge factor."""


def config_view(config: Mapping) -> GridView:
    """The view a model was trained under, from its config (``ndrql train --view``; ``native`` when the
    config has no ``view``; the shipped ``general`` model records ``coarse:128``)."""
    return GridView.parse(config.get("view") or "native")


def default_weights_path() -> Path:
    """``$NDRQL_WEIGHTS`` if set (a name or a path), else the shipped default weights
    (:data:`ndrql.model.weights.DEFAULT_WEIGHTS`)."""
    return resolve_weights(None)


#: Inference backends: ``auto`` is ONNX Runtime when it is installed and the model has both outputs
#: (:mod:`ndrql.model.onnx_backend`), else torch. Measured in docs/performance.md ("NDR model").
BACKENDS = ("auto", "onnx", "torch")


class Predictor:
    """A loaded NDR model: ``predict(obstacles, start, goal) -> Prediction`` at the map's size.

    The forward pass runs on torch or on ONNX Runtime (``backend``); both give the same probabilities
    to about 1e-4 (tested). ``backend_name`` says which one runs.
    """

    def __init__(self, runner, encoding: str = "point", input_mode: str = "map", view: GridView = GridView()):
        self._runner = runner
        self.encoding = encoding
        self.input_mode = input_mode
        """What the model was trained to see: ``map`` (the map resized) or ``grid`` (the planning grid at 4 px per cell)."""
        self.view = view
        """How a grid-mode model sees a planning grid (:class:`~ndrql.dataset.views.GridView`, from its config)."""
        self.symmetries = 1
        """Grid-mode predictions average over this many orientations of the grid (1, 2, 4 or 8;
        :mod:`ndrql.model.symmetry`); set by :meth:`load` or :meth:`with_symmetries`."""
        self.weights_file: Path | None = None
        """The file :meth:`load` read (``None`` for an in-memory model)."""
        self.merged_weights: Path | None = None
        """The companion serving the grids :attr:`view` merges (:mod:`ndrql.model.companion`), or ``None``."""
        self._threads = 0
        self._companion: dict[str, Any] = {}
        """The loaded companion (key ``"net"``) and its file's size and modification time (``"stat"``), shared by
        every :meth:`with_symmetries` copy."""

    def with_symmetries(self, count: int) -> "Predictor":
        """This model averaging its grid-mode predictions over ``count`` orientations (a new Predictor
        sharing the loaded network, and the companion's; ``ValueError`` for a count not in 1, 2, 4, 8)."""
        check_count(count, NdrqlError)
        out = Predictor(self._runner, self.encoding, self.input_mode, self.view)
        out.symmetries = count
        out.weights_file, out.merged_weights, out._threads = self.weights_file, self.merged_weights, self._threads
        out._companion = self._companion
        return out

    def serving(self, n: int) -> "Predictor":
        """The model that serves a grid of ``n`` cells on its longer side: the companion
        (:attr:`merged_weights`, loaded on first use with this backend, threads and symmetries) when
        :attr:`view` merges such a grid, else this one. A replaced companion file is loaded again."""
        if self.merged_weights is None or self.view.factor(int(n)) == 1:
            return self
        base, path = self.weights_file or Path("?"), self.merged_weights
        try:
            st = path.stat()
        except OSError:
            raise missing_companion(base, path) from None
        if self._companion.get("stat") != (st.st_size, st.st_mtime_ns):  # not loaded yet, or the file was replaced
            net = Predictor.load(path, self._threads, self.backend_name)
            check_companion(base, path, (self.encoding, self.input_mode), (net.encoding, net.input_mode))
            net.merged_weights = None  # a companion's own companion is not followed
            self._companion.update(net=net, stat=(st.st_size, st.st_mtime_ns))
        net = self._companion["net"]
        return net if self.symmetries == 1 else net.with_symmetries(self.symmetries)

    @property
    def weights_digest(self) -> str:
        """SHA-256 of the weights behind this model's predictions, covering its companion
        (:func:`ndrql.model.companion.weights_digest`); ``ValueError`` for an in-memory model."""
        if self.weights_file is None:
            raise ValueError("an in-memory model has no weights file to digest")
        return weights_digest(self.weights_file, self.merged_weights)

    @property
    def threads(self) -> int:
        """Intra-op threads the model runs on (0: the backend's default)."""
        return self._threads

    @property
    def backend_name(self) -> str:
        return self._runner.name

    @property
    def graph_file(self) -> Path | None:
        """The ONNX graph that runs (the weights' export, or the ``.onnx`` given); ``None`` on torch."""
        return getattr(self._runner, "path", None)

    @property
    def model(self):
        """The torch module (torch backend only)."""
        if not isinstance(self._runner, TorchRunner):
            raise AttributeError("this Predictor runs on ONNX Runtime; load it with backend='torch' for the torch module")
        return self._runner.model

    @classmethod
    def from_model(cls, model, encoding: str = "point", threads: int = 0, view: GridView | str = GridView()) -> "Predictor":
        """Wrap an in-memory torch model (eager backend) that sees planning grids through ``view`` (a
        :class:`~ndrql.dataset.views.GridView` or its text, ``"coarse:128"``)."""
        return cls(TorchRunner(model, threads), encoding, view=GridView.parse(str(view)))

    @classmethod
    def load(cls, path: str | Path | None = None, threads: int = 0, backend: str = "auto", symmetries: int = 1) -> "Predictor":
        """Load weights from ``path`` (default: :func:`default_weights_path`) on ``backend`` (:data:`BACKENDS`),
        averaging grid-mode predictions over ``symmetries`` orientations (:meth:`with_symmetries`).

        The shipped weights and ``.onnx`` files run on ONNX Runtime without torch; other checkpoints are
        exported once (torch) or run on torch. Without torch, whatever needs it is one clear error."""
        if backend not in BACKENDS:
            raise NdrqlError(f"unknown inference backend {backend!r}; valid: {', '.join(BACKENDS)}")
        check_threads(threads, "threads", 0)
        if symmetries != 1:
            return cls.load(path, threads, backend).with_symmetries(symmetries)
        path = resolve_weights(path)
        if not path.is_file():
            raise CheckpointError(
                f"missing model weights: {path} (reinstall ndrql, set NDRQL_WEIGHTS, or pass --weights / --prior-from)"
            )
        is_graph = path.suffix.lower() == ".onnx"
        if backend == "torch" and is_graph:
            raise NdrqlError(f"{path} is an ONNX graph: it runs on --backend onnx or auto, not torch")
        if backend != "torch" and not onnx_available():
            if backend == "onnx" or is_graph:
                raise NdrqlError("the ONNX backend needs onnxruntime: pip install onnxruntime")
        elif backend != "torch":
            try:
                runner = onnx_runner(path, threads, export=cached_export)
            except (CheckpointError, MissingDependency):
                raise
            except Exception as exc:  # an unwritable cache, a failed export or session: torch still works
                if is_graph and isinstance(exc, NdrqlError):
                    raise
                if backend == "onnx" or is_graph or not can_export():
                    raise NdrqlError(f"ONNX Runtime backend failed for {path}: {type(exc).__name__}: {exc}") from None
                import warnings

                warnings.warn(f"ONNX Runtime backend unavailable ({type(exc).__name__}: {exc}); using torch", stacklevel=2)
            else:
                if runner is not None:
                    return cls(runner, encoding=runner.config.get("encoding", "point"),
                               input_mode=runner.config.get("input_mode", "map"),
                               view=config_view(runner.config))._loaded(path, threads, runner.config)
                if backend == "onnx" and not can_export():
                    raise MissingDependency(f"running {path.name} on ONNX Runtime needs an export first, with torch and "
                                            f"onnx: {TRAIN_INSTALL} (or pass a graph from `ndrql export-onnx`)")
                if backend == "onnx":
                    raise NdrqlError(f"{path} holds a model without a guideline output; the ONNX backend needs both outputs")
        require_torch("--backend torch" if backend == "torch" else f"the checkpoint {path.name} (no ONNX graph of it here)")
        from ndrql.model.checkpoint import load_checkpoint, model_from_checkpoint  # lazy: loads torch

        data = load_checkpoint(path)
        config = dict(data["config"])
        out = cls.from_model(model_from_checkpoint(data), config.get("encoding", "point"), threads, config_view(config))
        out.input_mode = config.get("input_mode", "map")
        return out._loaded(path, threads, config)

    def _loaded(self, path: Path, threads: int, config: Mapping) -> "Predictor":
        """This model, recording the file it came from, its threads and its companion (from ``config``)."""
        self.weights_file, self._threads = path, threads
        self.merged_weights = companion_path(path, config) if self.input_mode == "grid" else None
        return self

    def predict_batch(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Probabilities for an encoded batch (B, C, H, W) -> (B, H, W) arrays."""
        return self._runner(x)[:2]

    def predict_grid(self, blocked: np.ndarray, start_cell: Point, goal_cell: Point) -> tuple[np.ndarray, np.ndarray | None]:
        """Region and guideline of a grid-mode model for the planning grid ``blocked`` at 4 px per cell
        (:meth:`predict_grid_all`)."""
        return self.predict_grid_all(blocked, start_cell, goal_cell)[:2]

    @property
    def sees_unknown(self) -> bool:
        """Whether the model has an unknown channel (a model for belief maps, encoding ``point+unknown``)."""
        return has_unknown(self.encoding)

    def predict_view(self, blocked: np.ndarray, start_cell: Point, goal_cell: Point,
                     companion: bool = True, unknown: np.ndarray | None = None) -> CellPrediction:
        """A grid-mode model's outputs per planning cell of ``blocked``: the input drawn through :attr:`view`
        (:func:`~ndrql.dataset.views.view_input`; ``native`` is the grid at 4 px per cell, padded with
        obstacles to a square of ``4 max(h, w)`` px), averaged over :attr:`symmetries` orientations, and
        brought back per planning cell (:func:`~ndrql.dataset.views.view_cells`,
        :func:`~ndrql.dataset.views.view_distance_cells`). A grid the view merges goes to the companion
        (:meth:`serving`) unless ``companion`` is ``False``: then this model predicts it through its own view.
        ``unknown``: the planning cells unknown to the planner (``blocked`` counts them free); a model with the
        unknown channel sees them (:attr:`sees_unknown`), one without predicts on ``blocked`` alone."""
        served = self.serving(max(np.shape(blocked))) if companion else self
        if served is not self:  # a grid the view merges: the companion's
            return served.predict_view(blocked, start_cell, goal_cell, unknown=unknown)
        hidden = unknown if self.sees_unknown else None
        seen = view_input(np.asarray(blocked, bool), tuple(start_cell), tuple(goal_cell), self.view, hidden)
        x = encode_input(seen.image, seen.start, seen.goal, self.encoding, seen.unknown)[None]
        r, gl, d = averaged(self._runner, x, self.symmetries)
        return CellPrediction(view_cells(r[0], seen), None if gl is None else view_cells(gl[0], seen),
                              None if d is None else view_distance_cells(d[0], seen), seen)

    def predict_cells(self, blocked: np.ndarray, start_cell: Point, goal_cell: Point
                      ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """Region, guideline and goal distance (cells) per planning cell of ``blocked``, float64 ``(h, w)``
        (:meth:`predict_view`; ``None`` for an output the model does not have)."""
        out = self.predict_view(blocked, start_cell, goal_cell)
        return out.region, out.guideline, out.distance

    def predict_grid_all(self, blocked: np.ndarray, start_cell: Point, goal_cell: Point
                         ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """:meth:`predict_grid` plus the goal distance, in planning cells, drawn at 4 px per planning cell on a
        square of ``4 max(h, w)`` px (``None`` for a model without a distance head). Under a view that shows
        the grid at 4 px per cell unmerged (``native``, and any view on a grid it leaves as it is) these are
        the model's own pixels; otherwise each planning cell's :meth:`predict_cells` value drawn over its 4x4
        pixels (padding 0), so that :func:`~ndrql.dataset.render.cell_means` of them is :meth:`predict_cells` to
        rounding (:class:`~ndrql.pipeline.samples.PredictionCache` stores such per-cell values as they are and
        calls this only where the model's own pixels exist)."""
        if self.view.shows_native(max(np.shape(blocked))):
            seen = view_input(np.asarray(blocked, bool), tuple(start_cell), tuple(goal_cell), self.view)
            r, gl, d = averaged(self._runner, encode_input(seen.image, seen.start, seen.goal, self.encoding)[None],
                                self.symmetries)
            dist = None if d is None else manhattan_pixels(seen.goal, seen.image.shape[0]) + DISTANCE_UNIT * d[0]
            return r[0], None if gl is None else gl[0], dist
        side = PX_PER_CELL * max(np.shape(blocked))
        return tuple(None if a is None else _drawn(a, side) for a in self.predict_cells(blocked, start_cell, goal_cell))  # type: ignore[return-value]

    def predict(self, obstacles: np.ndarray, start: Point, goal: Point, size: int | None = None) -> Prediction:
        """Region and guideline probabilities for one map, at the map's own resolution.

        A ``map``-mode model (the paper's) sees the map resized to 201 px. A ``grid``-mode model sees
        what ``ndrql plan`` plans on: the safe grid of ``size`` cells on the longer side (default: the
        size ``--size auto`` picks, without robot inflation), start and goal placed as ``plan`` places
        them; each map pixel then takes its cell's mean (``Prediction.grid`` holds the per-cell arrays).
        ``size`` is ignored for map-mode models.
        """
        obstacles = np.asarray(obstacles, bool)
        for name, p in (("start", start), ("goal", goal)):
            if not (0 <= p[0] < obstacles.shape[0] and 0 <= p[1] < obstacles.shape[1]):
                raise PointError(f"{name} {tuple(p)} is outside the {obstacles.shape[0]}x{obstacles.shape[1]} map")
        if self.input_mode == "grid":
            return self._predict_safe_grid(obstacles, tuple(start), tuple(goal), size)
        grid, s, g, scale = to_model_input(obstacles, start, goal)
        r, gl = self.predict_batch(encode_input(grid, s, g, self.encoding)[None])
        region = from_model_output(r[0], obstacles.shape, scale)
        guide = from_model_output(gl[0], obstacles.shape, scale) if gl is not None else None
        return Prediction(region=region, guideline=guide)

    def _predict_safe_grid(self, obstacles: np.ndarray, start: Point, goal: Point, size: int | None) -> Prediction:
        if size is None:
            size = choose_size(obstacles, start, goal, full_route(obstacles, start, goal).cost, DEFAULT_MAX_SIZE).size
        pg = sizing.safe_grid(obstacles, int(size), start, goal)
        blocked, s, g = pg.blocked, pg.start, pg.goal
        cells = self.predict_cells(blocked, s, g)
        cell_px = (cell_size_px(obstacles.shape, int(size)),) * 2
        on_map = [None if a is None else cells_to_map(a, obstacles.shape, cell_px) for a in cells[:2]]
        return Prediction(region=on_map[0], guideline=on_map[1],
                          grid=GridPrediction(int(size), blocked, s, g, cells[0], cells[1], cells[2]))


def _drawn(cells: np.ndarray, side: int) -> np.ndarray:
    """Values per planning cell drawn at 4 px per cell on a ``side`` square (padding 0)."""
    out = np.zeros((side, side), np.float64)
    up = np.kron(np.asarray(cells, np.float64), np.ones((PX_PER_CELL, PX_PER_CELL)))
    out[:up.shape[0], :up.shape[1]] = up
    return out


def load_predictor(weights: str | os.PathLike | None = None, threads: int = 1, backend: str = "auto",
                   symmetries: int = 1) -> Predictor:
    """The NDR model for ``weights`` (default: ``$NDRQL_WEIGHTS`` or the shipped file), loaded once per process.

    Loaded models are cached by path, size, modification time, threads and backend, so a second call
    is free and a replaced weights file is picked up. A missing or unreadable file raises
    :class:`~ndrql.errors.CheckpointError` with what to do. ``backend``: ``auto`` (ONNX Runtime when
    installed: the shipped models and ``.onnx`` files never import torch, other checkpoints once their
    export is cached), ``onnx`` or ``torch``. ``symmetries``: see :meth:`Predictor.with_symmetries`.
    """
    path = resolve_weights(weights)
    try:
        st = path.stat()
        key = (str(path.resolve()), st.st_size, st.st_mtime_ns)
    except OSError:
        key = (str(path), -1, -1)  # Predictor.load gives the clear "missing model weights" error
    check_count(symmetries, NdrqlError)
    return _cached_predictor(key, threads, backend, symmetries)


@functools.lru_cache(maxsize=8)
def _cached_predictor(key: tuple[str, int, int], threads: int, backend: str, symmetries: int) -> Predictor:
    if symmetries != 1:
        return _cached_predictor(key, threads, backend, 1).with_symmetries(symmetries)  # one network in memory
    return Predictor.load(key[0], threads=threads, backend=backend)


def predict(obstacles: np.ndarray, start: Point, goal: Point, weights: str | Path | None = None,
            backend: str = "auto", size: int | None = None, symmetries: int = DEFAULT_COUNT) -> Prediction:
    """One-shot prediction with the shipped (or given) weights (``size``: see :meth:`Predictor.predict`;
    ``symmetries``: :meth:`Predictor.with_symmetries`, ``ndrql plan``'s default)."""
    return Predictor.load(weights, backend=backend, symmetries=symmetries).predict(obstacles, start, goal, size)
