"""Map writers: PNG (black = obstacle, white = free) and ``.npy`` (bool), written atomically.

Each writer writes to a temporary file in the target's directory and renames it over the target
(``os.replace``), so a reader never sees a half-written map.
"""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import numpy as np

from ndrql.errors import MapFormatError
from ndrql.maps.grid import GridMap


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it replaces ``path``, on error it is removed."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise MapFormatError(f"cannot write {path}: directory {parent} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def _obstacles(grid_map: GridMap | np.ndarray) -> np.ndarray:
    arr = grid_map.obstacles if isinstance(grid_map, GridMap) else np.asarray(grid_map)
    if arr.ndim != 2:
        raise ValueError(f"a map is a 2-D array, got shape {arr.shape}")
    return arr.astype(bool)


def write_png(grid_map: GridMap | np.ndarray, path: str | Path) -> Path:
    """Write a map as an 8-bit grayscale PNG: obstacle 0 (black), free 255 (white)."""
    from PIL import Image

    img = Image.fromarray(np.where(_obstacles(grid_map), 0, 255).astype(np.uint8), mode="L")
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            img.save(fh, format="PNG", optimize=True)
    return Path(path)


def write_npy(grid_map: GridMap | np.ndarray, path: str | Path) -> Path:
    """Write a map as a boolean ``.npy`` array (``True`` = obstacle)."""
    arr = _obstacles(grid_map)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            np.save(fh, arr, allow_pickle=False)
    return Path(path)


def save_map(grid_map: GridMap | np.ndarray, path: str | Path) -> Path:
    """Write a map, choosing the format by extension (``.png`` or ``.npy``)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".png":
        return write_png(grid_map, path)
    if suffix == ".npy":
        return write_npy(grid_map, path)
    raise MapFormatError(f"cannot write maps as {suffix or '(no extension)'!r}; use .png or .npy")
