"""Map writers: PNG (black = obstacle, white = free) and ``.npy`` (bool).

Both go through the project's one output writer (:mod:`ndrql.io`): atomic replace, symlinks
followed, FIFOs and devices written directly, the umask's permissions, parent folders created.
``atomic_path`` is re-exported from there for existing callers.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ndrql.errors import MapFormatError
from ndrql.io import atomic_path, atomic_write
from ndrql.maps.grid import GridMap

__all__ = ["atomic_path", "save_map", "write_npy", "write_png"]


def _obstacles(grid_map: GridMap | np.ndarray) -> np.ndarray:
    arr = grid_map.obstacles if isinstance(grid_map, GridMap) else np.asarray(grid_map)
    if arr.ndim != 2:
        raise ValueError(f"a map is a 2-D array, got shape {arr.shape}")
    return arr.astype(bool)


def write_png(grid_map: GridMap | np.ndarray, path: str | Path) -> Path:
    """Write a map as an 8-bit grayscale PNG: obstacle 0 (black), free 255 (white)."""
    from PIL import Image

    img = Image.fromarray(np.where(_obstacles(grid_map), 0, 255).astype(np.uint8), mode="L")
    return atomic_write(path, lambda fh: img.save(fh, format="PNG", optimize=True))


def write_npy(grid_map: GridMap | np.ndarray, path: str | Path) -> Path:
    """Write a map as a boolean ``.npy`` array (``True`` = obstacle)."""
    arr = _obstacles(grid_map)
    return atomic_write(path, lambda fh: np.save(fh, arr, allow_pickle=False))


def save_map(grid_map: GridMap | np.ndarray, path: str | Path) -> Path:
    """Write a map, choosing the format by extension (``.png`` or ``.npy``)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".png":
        return write_png(grid_map, path)
    if suffix == ".npy":
        return write_npy(grid_map, path)
    raise MapFormatError(f"cannot write maps as {suffix or '(no extension)'!r}; use .png or .npy")
