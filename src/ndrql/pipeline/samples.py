"""Dataset samples as planning problems, cached NDR predictions, and the oracle's priors.

A :class:`Problem` is what every planning experiment and the tuning search run on: the 50x50
planning grid, start and goal cells, the A* length and (for N-* methods) the NDR region/guideline
downscaled to the grid, with the map it came from.
Predictions are made once per sample with a :class:`~ndrql.model.predict.Predictor` and cached as
``.npz`` (float16: at the map's resolution, or for a grid-mode model its pixels at 4 px per planning cell,
or one value per cell when its view merges or shrinks cells) under ``<results>/predictions/``, keyed by
the weights' digest,
so a different model never reuses a stale prediction. :class:`OraclePriors` gives the same two
methods (``attach``, ``full``) from each problem's own planning-grid shortest path instead of a model.
"""

from __future__ import annotations

import zipfile
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ndrql.dataset.layout import load_sample
from ndrql.dataset.render import PX_PER_CELL
from ndrql.errors import NdrqlError, NoPathError
from ndrql.io import data_digest, save_npz
from ndrql.maps.astar import astar4
from ndrql.maps.grid import PLANNING_SIZE, PlanningGrid
from ndrql.maps.problem import MapProblem
from ndrql.model.companion import companion_path, weights_digest
from ndrql.model.predict import Predictor
from ndrql.model.symmetry import digest_suffix
from ndrql.model.weights import PAPER_WEIGHTS, resolve_weights
from ndrql.pipeline.predictions import predict_on_grid
from ndrql.dataset.render import cell_means, grid_cells_to_map, to_map_pixels
from ndrql.maps.safe import grid_shape
from ndrql.planning.methods import downscale_priors
from ndrql.synth.oracle import ORACLE_NAME, oracle_prediction


@dataclass(frozen=True)
class Problem:
    """One planning problem: a map (a dataset sample, or a hand-made one) and its planning grid.

    The map with its start and goal pixels is :attr:`source` (one :class:`~ndrql.maps.problem.MapProblem`);
    ``start`` and ``goal`` here are cells of the planning grid."""

    split: str
    """Dataset split (``train``, ``seen``, ``unseen``) or any name for a hand-made map."""
    index: int
    category: str
    source: MapProblem
    """The map at full resolution (e.g. 201x201, ``True`` = obstacle) with the start and goal pixels."""
    blocked: np.ndarray
    """Planning grid (50x50)."""
    start: tuple[int, int]
    goal: tuple[int, int]
    astar: int
    """Optimal 4-connected moves on the planning grid."""
    region: np.ndarray | None = None
    """NDR region at planning-grid shape (``None`` until predictions are attached)."""
    guideline: np.ndarray | None = None
    distance: np.ndarray | None = None
    """The model's goal distance per planning cell (models with a distance head), for Eq. 6."""

    @property
    def key(self) -> str:
        """``<split>-<index>``: names the problem in results, caches and tuning studies."""
        return f"{self.split}-{self.index}"

    @property
    def obstacles(self) -> np.ndarray:
        """The map (:attr:`source`'s obstacles)."""
        return self.source.obstacles

    @property
    def source_start(self) -> tuple[int, int]:
        """The start pixel on the map (:attr:`source`'s start)."""
        return self.source.start

    @property
    def source_goal(self) -> tuple[int, int]:
        """The goal pixel on the map (:attr:`source`'s goal)."""
        return self.source.goal


def load_problem(root: str | Path, split: str, index: int, size: int = PLANNING_SIZE) -> Problem:
    """Problem of a dataset sample; raises :class:`NoPathError` when start and goal are not
    4-connected on the planning grid (docs/method.md: experiments skip such samples and count them)."""
    s = load_sample(root, split, index)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # snapping is expected on some samples; the grid records it
        pg = PlanningGrid.from_map(s.map, s.start, s.goal, size=size)
    opt = int(astar4(pg.blocked, pg.start, pg.goal).moves)
    source = MapProblem(s.map, tuple(s.start), tuple(s.goal))  # type: ignore[arg-type]
    return Problem(s.split, s.index, s.category, source, np.array(pg.blocked), tuple(pg.start),  # type: ignore[arg-type]
                   tuple(pg.goal), opt)  # type: ignore[arg-type]


def load_problems(root: str | Path, refs: list[tuple[str, int]],
                  size: int = PLANNING_SIZE) -> tuple[list[Problem], list[dict]]:
    """Problems for ``(split, index)`` pairs, and the skipped ones with the reason."""
    out, skipped = [], []
    for split, index in refs:
        try:
            out.append(load_problem(root, split, index, size))
        except NoPathError as exc:
            skipped.append({"split": split, "index": index, "reason": f"disconnected on the planning grid: {exc}"})
    return out, skipped


def _seen(weights: Path) -> tuple[str, Path | None]:
    """What the model in the checkpoint ``weights`` sees (its config's ``input_mode``) and its companion
    (:func:`ndrql.model.companion.companion_path`)."""
    from ndrql.model.checkpoint import load_checkpoint  # lazy: loads torch

    config = dict(load_checkpoint(weights)["config"])
    mode = str(config.get("input_mode", "map"))
    return mode, companion_path(weights, config) if mode == "grid" else None


#: How a ``cells`` entry was made: :func:`~ndrql.pipeline.predictions.predict_on_grid`, plan's own call with the
#: model source (one forward of the model that serves the grid: the companion on a grid the view merges). An entry
#: with another rule (the relay and the second opinion of earlier releases) is predicted again; the entry's digest
#: (:attr:`PredictionCache.digest`) covers the weights and the companion, every file the source reads.
CELLS_RULE = "one-forward"


class PredictionCache:
    """NDR predictions per sample, made once and kept on disk (module docstring)."""

    prior_from = "model"
    """Where the priors come from: a model (the weights in :attr:`weights`)."""

    def __init__(self, cache_dir: str | Path, weights: str | Path | None = None, threads: int = 1, symmetries: int = 1):
        self.dir = Path(cache_dir)
        self.symmetries = symmetries
        """Grid-mode models average over this many orientations of the grid (``ndrql plan`` does over
        :data:`~ndrql.model.symmetry.DEFAULT_COUNT`); part of :attr:`digest` when not 1; always 1 for a
        map-mode model."""
        self.weights = resolve_weights(weights, PAPER_WEIGHTS)
        if not self.weights.is_file():
            raise NdrqlError(
                f"missing model weights {self.weights}: the N-C/N-Q/NDR-QL rows need the NDR model "
                "(set NDRQL_WEIGHTS or pass --weights FILE)"
            )
        mode, companion = _seen(self.weights)
        if symmetries != 1 and mode != "grid":
            self.symmetries = symmetries = 1  # a map-mode model (the paper's) sees the map, never turned
        self.digest = weights_digest(self.weights, companion)[:16] + digest_suffix(symmetries)
        """Names the predictions in task fingerprints and cache entries: the weights (with the companion
        serving the grids the view merges, :mod:`ndrql.model.companion`) and the symmetries."""
        self.threads = threads
        self._predictor: Any = None
        self.computed = 0

    def describe(self) -> dict[str, str]:
        return {"weights": str(self.weights), "weights_sha256_16": self.digest}

    def path(self, p: Problem) -> Path:
        return self.dir / f"{p.key}.npz"

    def _entry(self, p: Problem) -> tuple[str, np.ndarray, np.ndarray, np.ndarray | None]:
        """``(mode, region, guideline, distance)`` as the model gave them (float32): ``map``, at the map's
        resolution (map-mode models); ``grid``, the model's own pixels at 4 px per cell of the planning grid (a
        grid-mode model whose view shows the grid as ``native`` does); ``cells``, one value per planning cell (a
        view that merges or shrinks cells: per-cell values are all it has). ``distance`` (cells) from a model
        with a distance head, else ``None``. Entries written before ``cells`` existed hold such values drawn
        over each cell's 4x4 pixels under ``grid``, which gives the same numbers."""
        path = self.path(p)
        inputs = data_digest(np.packbits(p.obstacles), repr((p.source_start, p.source_goal)),
                             np.packbits(p.blocked), repr((p.start, p.goal)))[:16]  # grid models see the grid
        if path.is_file():
            try:
                with np.load(path, allow_pickle=False) as d:
                    mode = str(d["mode"]) if "mode" in d.files else "map"
                    current = mode != "cells" or ("rule" in d.files and str(d["rule"]) == CELLS_RULE)
                    if str(d["weights"]) == self.digest and str(d["inputs"]) == inputs and current:
                        dist = d["distance"].astype(np.float32) if "distance" in d.files else None
                        return mode, d["region"].astype(np.float32), d["guideline"].astype(np.float32), dist
            except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
                pass  # a damaged cache entry is predicted again
        if self._predictor is None:
            # torch, not ONNX Runtime: the tables in docs/results.md were made with it, and the two
            # backends differ by ~1e-4 in probability, which could move a run; same numbers on re-runs
            self._predictor = Predictor.load(self.weights, threads=self.threads, backend="torch", symmetries=self.symmetries)
        mode = getattr(self._predictor, "input_mode", "map")
        distance = None
        if mode == "grid" and not self._predictor.view.shows_native(max(p.blocked.shape)):
            mode = "cells"  # per planning cell, through the model's view and plan's second opinion
            region, guideline, _, distance = predict_on_grid(self._predictor, p.blocked, p.start, p.goal)
        elif mode == "grid":  # the model's own pixels, 4 px per planning cell (Predictor.predict_grid_all)
            region, guideline, distance = self._predictor.predict_grid_all(p.blocked, p.start, p.goal)
        else:
            pred = self._predictor.predict(p.obstacles, p.source_start, p.source_goal)
            region, guideline = pred.region, pred.guideline
        if guideline is None:
            raise NdrqlError(f"the model {self.weights} has no guideline output; N-C needs one")
        region, guideline = np.asarray(region).astype(np.float16), np.asarray(guideline).astype(np.float16)
        extra = {} if distance is None else {"distance": np.asarray(distance, np.float32)}  # fp16 would blur neighbours
        if mode == "cells":
            extra["rule"] = np.array(CELLS_RULE)
        save_npz(path, region=region, guideline=guideline, weights=np.array(self.digest), inputs=np.array(inputs),
                 mode=np.array(mode), **extra)
        self.computed += 1
        return mode, region.astype(np.float32), guideline.astype(np.float32), extra.get("distance")

    def full(self, p: Problem) -> tuple[np.ndarray, np.ndarray]:
        """Region and guideline at the map's resolution (float32), from the cache or the model (a grid-mode
        model's values per cell drawn back on the map's pixels)."""
        mode, region, guideline, _ = self._entry(p)
        if mode in GRID_MODES:
            n = max(p.blocked.shape)
            cells = grid_shape(p.obstacles.shape, n)
            return tuple(grid_cells_to_map(_per_cell(mode, a, cells), p.obstacles.shape, n).astype(np.float32)  # type: ignore[return-value]
                         for a in (region, guideline))
        return region, guideline

    def attach(self, p: Problem) -> Problem:
        """``p`` with region and guideline on its planning grid: area averaging of the map-resolution
        prediction (docs/method.md), or for a grid-mode model its values per cell (the exact 4x4 means of its
        pixels under ``native``), and its goal distance per cell when it has a distance head, for Eq. 6."""
        mode, region, guideline, distance = self._entry(p)
        if mode in GRID_MODES:
            shape = p.blocked.shape
            r, g = (np.clip(_per_cell(mode, a, shape), 0, 1) for a in (region, guideline))
            d = None if distance is None else _per_cell(mode, distance, shape)
            return replace(p, region=r, guideline=g, distance=d)
        r, g = downscale_priors(np.clip(region, 0, 1), np.clip(guideline, 0, 1), p.blocked.shape)
        return replace(p, region=r, guideline=g)


#: The cache's modes of a grid-mode model (:meth:`PredictionCache._entry`).
GRID_MODES = ("grid", "cells")


def _per_cell(mode: str, values: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """A grid-mode cache entry's values per cell of ``shape`` (float64): the exact 4x4 means of a ``grid``
    entry's pixels, a ``cells`` entry's own values (zero beyond its grid). For values drawn over each cell's
    4x4 pixels the two agree bit for bit: the cache holds float16 probabilities and float32 distances, and
    the float64 mean of 16 equal such numbers is exact."""
    if mode == "grid":
        return cell_means(values, shape)
    out = np.zeros(shape)
    h, w = min(shape[0], values.shape[0]), min(shape[1], values.shape[1])
    out[:h, :w] = values[:h, :w]
    return out


class OraclePriors:
    """Region and guideline drawn from each problem's own planning-grid shortest path, as the dataset draws
    its labels (:func:`ndrql.synth.oracle.oracle_prediction`, 4 px per cell): the priors of a perfect
    prediction. A diagnostic, never a method (it needs the answer); named "oracle priors" wherever
    :class:`PredictionCache` would name its weights. Cheap to draw, so nothing is cached."""

    prior_from = "oracle"
    weights = ORACLE_NAME
    """What the reports print where a model's weights file would be."""

    def describe(self) -> dict[str, str]:
        return {"weights": self.weights, "prior_from": self.prior_from}

    @staticmethod
    def _drawn(p: Problem) -> tuple[np.ndarray, np.ndarray]:
        """Region and guideline at 4 px per planning cell (float32 in {0, 1})."""
        return oracle_prediction(p.blocked, p.start, p.goal, PX_PER_CELL)

    def full(self, p: Problem) -> tuple[np.ndarray, np.ndarray]:
        """Region and guideline at the map's resolution (each map pixel takes its cell's mean; for figures)."""
        n = max(p.blocked.shape)
        return tuple(to_map_pixels(a, p.obstacles.shape, n).astype(np.float32) for a in self._drawn(p))  # type: ignore[return-value]

    def attach(self, p: Problem) -> Problem:
        """``p`` with the oracle's region and guideline on its planning grid (exact 4x4 means, Eqs. 3 and 6 take them)."""
        region, guideline = self._drawn(p)
        return replace(p, region=cell_means(region, p.blocked.shape), guideline=cell_means(guideline, p.blocked.shape))
