"""Prediction API: region and guideline probabilities for any map, with the shipped model by default.

Maps that are not 201x201 are brought to the model's scale first: the longer side is resized to
201 px (area averaging of the obstacle fraction, blocked at >= 0.5, the planning grid's rule), the
shorter side padded with obstacles to 201, start and goal scaled with it (snapped to the nearest
free pixel if the resize blocked them). Probabilities are mapped back to the map's own size.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from ndrql.errors import CheckpointError, PointError

#: Side of the square input the model was trained on.
MODEL_SIDE = 201
#: File name of the shipped weights inside ``ndrql/data``.
WEIGHTS_NAME = "ndr_default.pt"

Point = tuple[int, int]


@dataclass(frozen=True)
class Prediction:
    """Model output at the map's resolution, probabilities in [0, 1]."""

    region: np.ndarray
    guideline: np.ndarray | None


def default_weights_path() -> Path:
    """``$NDRQL_WEIGHTS`` if set, else the weights shipped inside the package."""
    env = os.environ.get("NDRQL_WEIGHTS")
    if env:
        return Path(env)
    return Path(str(resources.files("ndrql") / "data" / WEIGHTS_NAME))


def point_on_grid(p: Point, scale: float, side: int) -> Point:
    """Where a pixel centre lands after scaling the map by ``scale`` (clamped to the grid)."""
    return (min(side - 1, int((p[0] + 0.5) * scale)), min(side - 1, int((p[1] + 0.5) * scale)))


def nearest_free(obstacles: np.ndarray, p: Point) -> Point:
    """``p`` itself when free, else the nearest free pixel (Euclidean)."""
    if not obstacles[p]:
        return p
    free = np.argwhere(~obstacles)
    if len(free) == 0:
        raise PointError("the map has no free cell")
    d = ((free - np.asarray(p)) ** 2).sum(1)
    r, c = free[int(np.argmin(d))]
    return (int(r), int(c))


def to_model_input(obstacles: np.ndarray, start: Point, goal: Point, side: int = MODEL_SIDE) -> tuple[np.ndarray, Point, Point, float]:
    """Resize/pad a map to ``side`` x ``side`` (see module docstring); returns map, start, goal, scale."""
    obstacles = np.asarray(obstacles, bool)
    h, w = obstacles.shape
    if (h, w) == (side, side):
        return obstacles, tuple(start), tuple(goal), 1.0
    scale = side / max(h, w)
    nh, nw = max(1, round(h * scale)), max(1, round(w * scale))
    # area averaging via per-pixel bin membership (works for up- and downscaling)
    rows = np.minimum((np.arange(h) * nh) // h, nh - 1)
    cols = np.minimum((np.arange(w) * nw) // w, nw - 1)
    if h >= nh and w >= nw:
        sums = np.zeros((nh, nw))
        counts = np.zeros((nh, nw))
        np.add.at(sums, (rows[:, None], cols[None, :]), obstacles.astype(np.float64))
        np.add.at(counts, (rows[:, None], cols[None, :]), 1.0)
        small = sums / np.maximum(counts, 1) >= 0.5
    else:  # upscaling: nearest source pixel
        src_r = np.minimum((np.arange(nh) * h) // nh, h - 1)
        src_c = np.minimum((np.arange(nw) * w) // nw, w - 1)
        small = obstacles[src_r[:, None], src_c[None, :]]
    out = np.ones((side, side), bool)
    out[:nh, :nw] = small
    s = nearest_free(out, point_on_grid(tuple(start), nh / h, side))
    g = nearest_free(out, point_on_grid(tuple(goal), nh / h, side))
    return out, s, g, scale


def from_model_output(prob: np.ndarray, shape: tuple[int, int], scale: float) -> np.ndarray:
    """Map a (side, side) probability back to the original map's ``shape`` (nearest sampling)."""
    if scale == 1.0 and prob.shape == shape:
        return prob
    h, w = shape
    r = np.minimum(((np.arange(h) + 0.5) * scale).astype(int), prob.shape[0] - 1)
    c = np.minimum(((np.arange(w) + 0.5) * scale).astype(int), prob.shape[1] - 1)
    return prob[r[:, None], c[None, :]]


class Predictor:
    """A loaded NDR model: ``predict(obstacles, start, goal) -> Prediction`` at the map's size."""

    def __init__(self, model, encoding: str = "point", threads: int = 0):
        import torch

        if threads:
            torch.set_num_threads(threads)
        self.model = model.eval()
        self.encoding = encoding

    @classmethod
    def load(cls, path: str | Path | None = None, threads: int = 0) -> "Predictor":
        """Load weights from ``path`` (default: :func:`default_weights_path`)."""
        from ndrql.training.checkpoint import load_checkpoint, model_from_checkpoint

        path = Path(path) if path is not None else default_weights_path()
        if not path.is_file():
            raise CheckpointError(
                f"missing model weights: {path} (reinstall ndrql, set NDRQL_WEIGHTS, or pass --weights / --prior-from)"
            )
        data = load_checkpoint(path)
        model = model_from_checkpoint(data)
        return cls(model, encoding=dict(data["config"]).get("encoding", "point"), threads=threads)

    def predict_batch(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Probabilities for an encoded batch (B, C, H, W) -> (B, H, W) arrays."""
        import torch

        with torch.inference_mode():
            region, guide = self.model(torch.from_numpy(np.ascontiguousarray(x, np.float32)))
        r = torch.sigmoid(region)[:, 0].numpy()
        g = torch.sigmoid(guide)[:, 0].numpy() if guide is not None else None
        return r, g

    def predict(self, obstacles: np.ndarray, start: Point, goal: Point) -> Prediction:
        """Region and guideline probabilities for one map, at the map's own resolution."""
        from ndrql.dataset.encodings import encode_input

        obstacles = np.asarray(obstacles, bool)
        for name, p in (("start", start), ("goal", goal)):
            if not (0 <= p[0] < obstacles.shape[0] and 0 <= p[1] < obstacles.shape[1]):
                raise PointError(f"{name} {tuple(p)} is outside the {obstacles.shape[0]}x{obstacles.shape[1]} map")
        grid, s, g, scale = to_model_input(obstacles, start, goal)
        r, gl = self.predict_batch(encode_input(grid, s, g, self.encoding)[None])
        region = from_model_output(r[0], obstacles.shape, scale)
        guide = from_model_output(gl[0], obstacles.shape, scale) if gl is not None else None
        return Prediction(region=region, guideline=guide)


def predict(obstacles: np.ndarray, start: Point, goal: Point, weights: str | Path | None = None) -> Prediction:
    """One-shot prediction with the shipped (or given) weights."""
    return Predictor.load(weights).predict(obstacles, start, goal)
