"""Beliefs for training sets: which kinds of mask a generated set draws, and drawing one per sample from a seed.

A generated set made with ``ndrql data generate --masks SPEC --mask-seed S`` stores, beside each true map,
a belief of it (:class:`~ndrql.maps.belief.Belief`, :mod:`ndrql.synth.masks`): the model for belief maps
learns from the belief (its input, with an unknown channel) and the true map's route (its labels).

``SPEC`` lists kinds, comma-separated (:func:`parse_masks`):

- ``blobs:LO-HI`` (or ``blobs:F``): a share of the free space drawn uniformly in ``LO..HI`` hidden in blobs;
- ``sensed``: what a robot saw driving 1-3 random routes from the start (radius 6-14% of the map's side);
- ``outdated``: gaps closed and thin walls opened, nothing unknown;
- ``none:SHARE``: the share of samples with nothing hidden (the true map known; default
  :data:`DEFAULT_NONE_SHARE`), so that the model keeps what it does on known maps.

Sample ``i`` draws from ``default_rng([mask_seed, i, 54])``: nothing hidden with probability ``SHARE``, else
one of the listed kinds, uniformly. ``blobs`` and ``sensed`` are drawn on the map reduced to at most
:data:`MASK_SIDE` px (a reduced pixel is an obstacle when any of its pixels is, so walls stay walls for the
sensor's rays) and brought back to the map's pixels; ``outdated`` at the map's own resolution. Start and goal
and the discs around them (:func:`~ndrql.synth.masks.keep_radius`) stay known.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ndrql.errors import NdrqlError
from ndrql.maps.belief import Belief, known
from ndrql.synth.masks import blobs, kept, outdated, sensed, sensing_routes

Point = tuple[int, int]

#: Share of samples with nothing hidden when the spec does not say (``none:SHARE``).
DEFAULT_NONE_SHARE = 0.2
#: Largest side (px) blobs and sensed masks are drawn at (the sensor's rays cost grows with the side cubed).
MASK_SIDE = 256
#: Kinds a spec may list besides ``none``.
MASK_KINDS = ("blobs", "sensed", "outdated")
#: Codes of the drawn kinds as a set's shards store them (index = code).
KIND_CODES = ("none", *MASK_KINDS)


@dataclass(frozen=True)
class MaskSpec:
    """Which beliefs a set draws: kinds (with the blobs' range of hidden shares) and the share of known maps."""

    kinds: tuple[str, ...]
    blob_range: tuple[float, float] = (0.1, 0.5)
    none_share: float = DEFAULT_NONE_SHARE

    def __post_init__(self) -> None:
        if not self.kinds or any(k not in MASK_KINDS for k in self.kinds) or len(set(self.kinds)) != len(self.kinds):
            raise NdrqlError(f"--masks lists kinds {', '.join(MASK_KINDS)} (each once) and none:SHARE, got "
                             f"{', '.join(self.kinds) or 'none'}")
        lo, hi = self.blob_range
        if not 0.0 < lo <= hi < 0.9:
            raise NdrqlError(f"--masks blobs:LO-HI needs 0 < LO <= HI < 0.9, got {lo:g}-{hi:g}")
        if not 0.0 <= self.none_share < 1.0:
            raise NdrqlError(f"--masks none:SHARE needs 0 <= SHARE < 1, got {self.none_share:g}")

    def __str__(self) -> str:
        parts = [f"blobs:{self.blob_range[0]:g}-{self.blob_range[1]:g}" if k == "blobs" else k for k in self.kinds]
        return ",".join([*parts, f"none:{self.none_share:g}"])


def _number(text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise NdrqlError(f"--masks: {what} must be a number, got {text!r}") from None
    if not np.isfinite(value):
        raise NdrqlError(f"--masks: {what} must be finite, got {text!r}")
    return value


def parse_masks(text: str) -> MaskSpec:
    """``"blobs:0.1-0.5,sensed,outdated,none:0.2"`` -> a :class:`MaskSpec` (one clear error otherwise)."""
    kinds: list[str] = []
    blob_range, none_share = (0.1, 0.5), DEFAULT_NONE_SHARE
    for part in (p.strip() for p in str(text).split(",")):
        if not part:
            continue
        kind, _, arg = part.partition(":")
        if kind == "none":
            none_share = _number(arg, "the share of none")
            continue
        if kind == "blobs" and arg:
            lo, _, hi = arg.partition("-")
            blob_range = (_number(lo, "blobs' share"), _number(hi or lo, "blobs' share"))
        elif arg:
            raise NdrqlError(f"--masks: {kind} takes no argument, got {part!r}")
        kinds.append(kind)
    return MaskSpec(tuple(kinds), blob_range, none_share)


def reduce_any(mask: np.ndarray, f: int) -> np.ndarray:
    """``f`` x ``f`` pixels into one, set when any of them is (the far edges padded with unset pixels)."""
    h, w = mask.shape
    H, W = -(-h // f), -(-w // f)
    pad = np.zeros((H * f, W * f), dtype=bool)
    pad[:h, :w] = mask
    return pad.reshape(H, f, W, f).any(axis=(1, 3))


def _reduced_unknown(kind: str, truth: np.ndarray, start: Point, goal: Point, rng: np.random.Generator,
                     spec: MaskSpec) -> np.ndarray:
    """The unknown pixels of a ``blobs`` or ``sensed`` belief drawn on the map reduced to at most MASK_SIDE px."""
    f = max(1, -(-max(truth.shape) // MASK_SIDE))
    small = reduce_any(truth, f)
    s, g = (start[0] // f, start[1] // f), (goal[0] // f, goal[1] // f)
    small[s] = small[g] = False  # the robot stands there: free at any scale
    if kind == "blobs":
        unknown = blobs(small, s, g, float(rng.uniform(*spec.blob_range)), rng).unknown
    else:
        radius = float(rng.uniform(0.06, 0.14)) * max(small.shape)
        routes = sensing_routes(small, s, rng, int(rng.integers(1, 4)))
        unknown = sensed(small, s, g, routes, radius).unknown
    full = np.kron(unknown, np.ones((f, f), dtype=bool))[:truth.shape[0], :truth.shape[1]]
    return full & ~kept(truth.shape, (start, goal), None)


def draw_training_belief(spec: MaskSpec, obstacles: np.ndarray, start: Point, goal: Point, mask_seed: int,
                         index: int) -> Belief:
    """The belief of sample ``index`` (module docstring): kind ``known`` when nothing is hidden."""
    truth = np.asarray(obstacles, dtype=bool)
    rng = np.random.default_rng([int(mask_seed), int(index), 54])
    if rng.random() < spec.none_share:
        return known(truth)
    kind = spec.kinds[int(rng.integers(len(spec.kinds)))]
    if kind == "outdated":
        return outdated(truth, start, goal, rng)
    try:
        return Belief(truth, _reduced_unknown(kind, truth, start, goal, rng, spec), kind=kind)
    except ValueError:  # too little free space to hide the drawn share: the map stays known
        return known(truth)


def kind_code(belief: Belief) -> int:
    """The code of ``belief``'s kind in :data:`KIND_CODES` (``known`` is ``none``)."""
    return KIND_CODES.index(belief.kind) if belief.kind in KIND_CODES else 0


__all__ = ["DEFAULT_NONE_SHARE", "KIND_CODES", "MASK_KINDS", "MASK_SIDE", "MaskSpec", "draw_training_belief",
           "kind_code", "parse_masks", "reduce_any"]
