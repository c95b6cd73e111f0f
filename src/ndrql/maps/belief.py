"""A belief map: what the planner knows of a map, next to the map the robot drives on.

A robot rarely knows its whole map: parts were never seen (a ROS map's unknown space, a region hidden
from the planner) or the map is outdated (a door closed since). A :class:`Belief` holds, at the map's
own resolution, the obstacles the planner believes in and the pixels it does not know. Everything a
planner decides before it learns reads the belief, with the unknown pixels counted free (Nav2's
``allow_unknown``) or as obstacles (:meth:`Belief.planner_obstacles`); the agent then acts on the true map.

:func:`read_mask` reads a mask the user gives (``ndrql plan --hide MASK``: a ``.npy`` array or an image of
the map's size, non-zero / not black = unknown); :func:`check_belief` refuses one the planner cannot use
(wrong size, start or goal unknown, all free space hidden). The generators of masks for studies and
training (blobs, what a robot sensed, an outdated map) are in :mod:`ndrql.synth.masks`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ndrql.errors import MapFormatError, PointError, brief

#: How a planner counts unknown pixels: as free space (Nav2's ``allow_unknown``) or as obstacles.
UNKNOWN_RULES = ("free", "obstacle")
#: File types a mask is read from.
MASK_SUFFIXES = (".npy", ".png", ".pgm", ".bmp", ".tif", ".tiff")


@dataclass(frozen=True, eq=False)
class Belief:
    """What the planner knows of a map (``(H, W)`` bool arrays at the map's resolution, read-only).

    ``obstacles``: the obstacles it believes in (never on an unknown pixel: those are cleared);
    ``unknown``: the pixels it does not know. An outdated map is a belief with no unknown pixel and wrong
    obstacles."""

    obstacles: np.ndarray = field(repr=False)
    unknown: np.ndarray = field(repr=False)
    kind: str = "given"
    """Where it came from (``given``, ``blobs``, ``sensed``, ``outdated``, ``ros``), for reports."""

    def __post_init__(self) -> None:
        obs, unk = np.asarray(self.obstacles, dtype=bool), np.asarray(self.unknown, dtype=bool)
        if obs.ndim != 2 or obs.shape != unk.shape:
            raise ValueError(f"a belief needs two 2-D arrays of one shape, got {obs.shape} and {unk.shape}")
        obs = obs & ~unk
        for name, arr in (("obstacles", obs), ("unknown", unk)):
            arr = np.array(arr, dtype=bool, copy=True)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def shape(self) -> tuple[int, int]:
        return self.obstacles.shape  # type: ignore[return-value]

    def planner_obstacles(self, unknown_as: str = "free") -> np.ndarray:
        """The obstacles a planner sees: the believed ones, plus the unknown pixels when ``unknown_as`` is
        ``obstacle``."""
        if unknown_as not in UNKNOWN_RULES:
            raise ValueError(f"unknown_as must be one of {', '.join(UNKNOWN_RULES)}, got {unknown_as!r}")
        return self.obstacles | self.unknown if unknown_as == "obstacle" else self.obstacles.copy()

    def unknown_share(self, truth: np.ndarray | None = None) -> float:
        """Share of the free space that is unknown: of the true free pixels when ``truth`` (obstacles) is
        given, else of the pixels not believed to be obstacles."""
        free = ~np.asarray(truth, dtype=bool) if truth is not None else ~self.obstacles
        n = int(free.sum())
        return float((self.unknown & free).sum() / n) if n else 0.0


def known(truth: np.ndarray) -> Belief:
    """The belief that knows ``truth`` (obstacles) exactly."""
    truth = np.asarray(truth, dtype=bool)
    return Belief(truth, np.zeros_like(truth), kind="known")


def hidden(truth: np.ndarray, unknown: np.ndarray, kind: str = "given") -> Belief:
    """The belief of a planner that knows ``truth`` except the ``unknown`` pixels."""
    return Belief(np.asarray(truth, dtype=bool), np.asarray(unknown, dtype=bool), kind=kind)


def unknown_cells(unknown_px: np.ndarray, grid: Any) -> np.ndarray:
    """The cells of the planning grid ``grid`` (a :class:`~ndrql.maps.grid.PlanningGrid`) holding at least one
    unknown pixel (a pixel belongs to the cell its centre falls in). What the model for belief maps sees as
    unknown is this on the cells its input shows free (:func:`ndrql.dataset.render.unknown_image`)."""
    h, w = grid.shape
    sr, sc = grid.cell_size
    rr, cc = np.nonzero(np.asarray(unknown_px, dtype=bool))
    out = np.zeros((h, w), dtype=bool)
    out[np.minimum(h - 1, (rr / sr).astype(np.int64)), np.minimum(w - 1, (cc / sc).astype(np.int64))] = True
    return out


def _mask_array(source: Any) -> tuple[np.ndarray, str]:
    if isinstance(source, np.ndarray):
        return source, "the mask array"
    if not isinstance(source, (str, os.PathLike)):
        raise MapFormatError(f"a mask is a .npy or image file or a 2-D array, got {brief(source)}")
    path = Path(source)
    what = f"mask {path}"
    if not path.is_file():
        raise MapFormatError(f"{what}: no such file")
    suffix = path.suffix.lower()
    if suffix == ".npy":
        try:
            arr = np.load(path, allow_pickle=False)
        except Exception as exc:  # numpy raises ValueError, OSError, EOFError, ... on a file that is not an array
            reason = str(exc).splitlines()[0][:160] if str(exc) else type(exc).__name__
            raise MapFormatError(f"{what} is not a mask (.npy array): {reason}") from None
        return arr, what
    if suffix in MASK_SUFFIXES:
        from PIL import Image

        try:
            with Image.open(path) as img:
                arr = np.asarray(img.convert("L"))
        except Exception as exc:  # Pillow raises many types on corrupt input
            reason = str(exc).splitlines()[0][:160] if str(exc) else type(exc).__name__
            raise MapFormatError(f"{what} is not a mask (image): {reason}") from None
        return arr, what
    raise MapFormatError(f"{what}: a mask is a .npy array or an image ({', '.join(MASK_SUFFIXES)}), "
                         f"not {suffix or 'a file without extension'}")


def read_mask(source: Any, shape: Sequence[int]) -> np.ndarray:
    """The unknown pixels of a mask (a ``.npy`` array, an image, or an array; non-zero = unknown) for a map of
    ``shape``; :class:`MapFormatError` for a file that is not a mask or a mask of another size."""
    arr, what = _mask_array(source)
    if not isinstance(arr, np.ndarray) or arr.ndim != 2 or arr.dtype.kind not in "biuf":
        raise MapFormatError(f"{what} is not a mask: expected a 2-D boolean or numeric array, got "
                             f"{getattr(arr, 'ndim', '?')}-D {getattr(arr, 'dtype', type(arr).__name__)}")
    if arr.dtype.kind == "f" and not np.isfinite(arr).all():
        raise MapFormatError(f"{what} is not a mask: it holds NaN or infinite values")
    if tuple(arr.shape) != tuple(shape):
        raise MapFormatError(f"{what} is {arr.shape[0]}x{arr.shape[1]} (rows x cols); the map is "
                             f"{shape[0]}x{shape[1]}: give a mask of the map's size")
    return np.asarray(arr != 0, dtype=bool)


def check_belief(belief: Belief, start: Sequence[int], goal: Sequence[int]) -> None:
    """Refuse a belief a planner cannot start from: start or goal unknown or believed blocked, or no known
    free pixel but them (:class:`PointError`, :class:`MapFormatError`)."""
    for name, p in (("start", start), ("goal", goal)):
        r, c = int(p[0]), int(p[1])
        if belief.unknown[r, c]:
            raise PointError(f"{name} {r},{c} is unknown to the planner (in the mask or the map's unknown space); a "
                             f"robot knows where it stands and where it goes: keep both known")
        if belief.obstacles[r, c]:
            raise PointError(f"{name} {r},{c} is an obstacle of the belief map")
    known_free = ~belief.unknown & ~belief.obstacles
    known_free[int(start[0]), int(start[1])] = known_free[int(goal[0]), int(goal[1])] = False
    if not known_free.any():
        raise MapFormatError("the mask hides every free pixel of the map but start and goal: nothing is known "
                             "to plan with")


__all__ = ["Belief", "MASK_SUFFIXES", "UNKNOWN_RULES", "check_belief", "hidden", "known", "read_mask", "unknown_cells"]
