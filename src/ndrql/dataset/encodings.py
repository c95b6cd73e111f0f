"""Input encodings of map, start and goal for the NDR model (docs/method.md; paper Table 4).

All return float32 arrays (C, H, W). ``point`` (default) is the paper's NDR input: map (1 = obstacle),
a single-pixel start channel and a single-pixel goal channel.

An encoding named ``BASE+unknown`` (:data:`UNKNOWN_ENCODINGS`: ``point+unknown``) is ``BASE``'s channels plus
one channel that is 1 on the pixels unknown to the planner (the model for belief maps): the map channel then
shows the belief with its unknown cells free. Without an unknown mask that channel is 0 (a known map).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

Point = tuple[int, int]


def encode_point(obstacles: np.ndarray, start: Point, goal: Point) -> np.ndarray:
    """Map, single-pixel start, single-pixel goal (3 channels)."""
    h, w = obstacles.shape
    out = np.zeros((3, h, w), np.float32)
    out[0] = obstacles
    out[1][start] = 1.0
    out[2][goal] = 1.0
    return out


def encode_rgb(obstacles: np.ndarray, start: Point, goal: Point) -> np.ndarray:
    """RGB-mixed image like RGP/NEED: free = white, obstacle = black, start red, goal blue."""
    free = (~obstacles.astype(bool)).astype(np.float32)
    out = np.stack([free, free, free])
    out[:, start[0], start[1]] = (1.0, 0.0, 0.0)
    out[:, goal[0], goal[1]] = (0.0, 0.0, 1.0)
    return out


def gaussian_channel(shape: tuple[int, int], point: Point, sigma: float) -> np.ndarray:
    """exp(-d^2 / (2 sigma^2)) around ``point``, peak 1."""
    rr = (np.arange(shape[0], dtype=np.float32) - point[0]) ** 2
    cc = (np.arange(shape[1], dtype=np.float32) - point[1]) ** 2
    return np.exp(-(rr[:, None] + cc[None, :]) / (2.0 * sigma * sigma)).astype(np.float32)


def make_gaussian(divisor: float) -> Callable[[np.ndarray, Point, Point], np.ndarray]:
    """Gaussian start/goal channels with sigma = side / divisor (paper: s/25 and s/50)."""

    def encode(obstacles: np.ndarray, start: Point, goal: Point) -> np.ndarray:
        sigma = max(obstacles.shape) / divisor
        return np.stack(
            [obstacles.astype(np.float32), gaussian_channel(obstacles.shape, start, sigma), gaussian_channel(obstacles.shape, goal, sigma)]
        )

    encode.__doc__ = f"Map plus Gaussian start/goal, sigma = side/{divisor:g}."
    return encode


def encode_distance(obstacles: np.ndarray, start: Point, goal: Point) -> np.ndarray:
    """Map plus Euclidean distance to start and to goal, normalised by the map diagonal."""
    h, w = obstacles.shape
    diag = float(np.hypot(h, w))
    rr, cc = np.mgrid[0:h, 0:w].astype(np.float32)
    ds = np.hypot(rr - start[0], cc - start[1]) / diag
    dg = np.hypot(rr - goal[0], cc - goal[1]) / diag
    return np.stack([obstacles.astype(np.float32), ds, dg]).astype(np.float32)


#: Encoding name -> function(obstacles, start, goal) -> (3, H, W) float32.
ENCODINGS: dict[str, Callable[[np.ndarray, Point, Point], np.ndarray]] = {
    "point": encode_point,
    "rgb": encode_rgb,
    "gauss25": make_gaussian(25),
    "gauss50": make_gaussian(50),
    "distance": encode_distance,
}


#: Encodings with an unknown channel (appended last) -> the encoding of their other channels.
UNKNOWN_ENCODINGS: dict[str, str] = {"point+unknown": "point"}


def has_unknown(name: str) -> bool:
    """Whether encoding ``name`` has the unknown channel."""
    return name in UNKNOWN_ENCODINGS


def encoding_channels(name: str) -> int:
    """Input channels of encoding ``name`` (3, and one more with the unknown channel)."""
    get_encoding(name)
    return 4 if has_unknown(name) else 3


def get_encoding(name: str) -> Callable[[np.ndarray, Point, Point], np.ndarray]:
    """Look up an encoding by name; the error lists the valid ones."""
    if name not in ENCODINGS and name not in UNKNOWN_ENCODINGS:
        raise ValueError(f"unknown input encoding {name!r}; valid: {', '.join([*ENCODINGS, *UNKNOWN_ENCODINGS])}")
    return ENCODINGS[UNKNOWN_ENCODINGS.get(name, name)]


def encode_input(obstacles: np.ndarray, start: Point, goal: Point, encoding: str = "point",
                 unknown: np.ndarray | None = None) -> np.ndarray:
    """Encode one (map, start, goal) as the model's (C, H, W) float32 input; ``unknown`` (bool, the map's
    shape) fills the unknown channel of an encoding that has one (``None``: zeros). ``ValueError`` for an
    unknown mask given to an encoding without the channel or of another shape."""
    obstacles = np.asarray(obstacles, bool)
    out = get_encoding(encoding)(obstacles, tuple(start), tuple(goal))
    if not has_unknown(encoding):
        if unknown is not None:
            raise ValueError(f"encoding {encoding!r} has no unknown channel; encode the belief with "
                             f"{', '.join(UNKNOWN_ENCODINGS)}")
        return out
    channel = np.zeros((1, *obstacles.shape), np.float32)
    if unknown is not None:
        if np.shape(unknown) != obstacles.shape:
            raise ValueError(f"unknown mask is {np.shape(unknown)}, the map {obstacles.shape}")
        channel[0] = np.asarray(unknown, bool)
    return np.concatenate([out, channel])
