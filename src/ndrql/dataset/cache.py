"""A compact local cache of the decoded dataset, so training never decodes a JPEG twice.

One ``.npz`` per split under ``$NDRQL_CACHE`` (default ``~/.cache/ndrql``), with bit-packed masks:
maps (per map file), start/goal, guideline and region per sample, category ids, and for UNSEEN the
original (upstream, broken for 900..1199) region labels resized to 201 px for the paper-comparable F1.

Each cache file has its SHA-256 beside it (``<split>.npz.sha256``); a file that does not match it or
does not load (a truncated write, a full disk) is decoded again once, with a warning. The decode
workers die with the process that started them (:mod:`ndrql.workers`).
"""

from __future__ import annotations

import warnings
import zipfile
import zlib
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from ndrql.dataset import layout
from ndrql.errors import DatasetError
from ndrql.io import cache_dir, data_digest, file_digest, save_npz, write_text
from ndrql.maps.grid import MODEL_SIDE
from ndrql.workers import process_pool

CACHE_VERSION = 1


def pack(mask: np.ndarray) -> np.ndarray:
    """Bit-pack a (..., 201, 201) bool mask along the last axis."""
    return np.packbits(mask.astype(bool), axis=-1)


def unpack(packed: np.ndarray, width: int = MODEL_SIDE) -> np.ndarray:
    """Inverse of :func:`pack`."""
    return np.unpackbits(packed, axis=-1, count=width).astype(bool)


@dataclass(frozen=True)
class SplitArrays:
    """Decoded split: packed masks and per-sample metadata (see module docstring)."""

    split: str
    maps: np.ndarray  # (n_maps, 201, 26) packed
    map_index: np.ndarray  # (n,) int
    points: np.ndarray  # (n, 4) int: start row, start col, goal row, goal col
    guideline: np.ndarray  # (n, 201, 26) packed
    region: np.ndarray  # (n, 201, 26) packed (corrected labels)
    region_original: np.ndarray  # (n, 201, 26) packed upstream labels (resized to 201 where needed)
    category: np.ndarray  # (n,) int category id within the split

    def __len__(self) -> int:
        return len(self.map_index)

    def obstacles(self, i: int) -> np.ndarray:
        """Obstacle mask of sample ``i``."""
        return unpack(self.maps[self.map_index[i]])


def _decode_sample(args: tuple[str, str, int]) -> tuple:
    root, split, i = args
    s = layout.load_sample(root, split, i)
    orig = s.region_original
    if orig is not None and orig.shape != (MODEL_SIDE, MODEL_SIDE):
        orig = layout.resize_bilinear_cv2(orig.astype(np.uint8) * 255, MODEL_SIDE, MODEL_SIDE) > 127
    elif orig is None:
        orig = s.region
    return (s.start + s.goal, pack(s.guideline), pack(s.region), pack(orig))


def _decode_map(args: tuple[str, str, int]) -> np.ndarray:
    root, split, i = args
    return pack(layout.load_map(root, split, i))


def cache_path(root: str | Path, split: str) -> Path:
    """Where the cache of ``split`` of the dataset at ``root`` lives (keyed by the root's real path)."""
    key = data_digest(str(Path(root).resolve()), algorithm="sha1")[:10]
    return cache_dir() / "dataset" / f"{key}-v{CACHE_VERSION}" / f"{split}.npz"


def build_split(root: str | Path, split: str, workers: int = 2, progress: bool = True) -> Path:
    """Decode a split once into its cache file (atomic write) and return the path."""
    from tqdm import tqdm

    split = layout.normalize_split(split)
    layout.check_root(root)
    path = cache_path(root, split)
    if path.exists():
        return path
    n = layout.count_samples(root, split)
    n_maps = min(n, 4000) if split == "train" else n
    root = str(root)
    with process_pool(workers) as pool:
        maps = list(
            tqdm(pool.map(_decode_map, [(root, split, i) for i in range(n_maps)], chunksize=64),
                 total=n_maps, desc=f"decode {split} maps", disable=not progress)
        )
        rows = list(
            tqdm(pool.map(_decode_sample, [(root, split, i) for i in range(n)], chunksize=64),
                 total=n, desc=f"decode {split} samples", disable=not progress)
        )
    arrays = {
        "maps": np.stack(maps),
        "map_index": np.array([layout.map_index(split, i) for i in range(n)], np.int32),
        "points": np.array([r[0] for r in rows], np.int16),
        "guideline": np.stack([r[1] for r in rows]),
        "region": np.stack([r[2] for r in rows]),
        "region_original": np.stack([r[3] for r in rows]),
        "category": np.array([layout.CATEGORIES[split].index(layout.category(split, i)) for i in range(n)], np.int8),
    }
    save_npz(path, arrays, compressed=False)
    write_text(digest_path(path), file_digest(path) + "\n")
    return path


def digest_path(path: Path) -> Path:
    """The file holding the SHA-256 of the cache file ``path``."""
    return path.with_name(path.name + ".sha256")


def _read(path: Path, split: str) -> SplitArrays | str:
    """The cached split, or why the file at ``path`` cannot be used (damaged or incomplete)."""
    try:
        recorded = digest_path(path).read_text().strip()
    except FileNotFoundError:
        recorded = None  # a cache written without a digest: trusted when it loads
    except OSError as exc:
        return f"unreadable digest ({exc.strerror})"
    if recorded is not None and file_digest(path) != recorded:
        return "its SHA-256 does not match"
    expected = {f.name for f in fields(SplitArrays)} - {"split"}
    try:
        with np.load(path, allow_pickle=False) as z:
            if set(z.files) != expected:
                return "unexpected contents"
            return SplitArrays(split=split, **{k: z[k] for k in z.files})
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as exc:
        return f"{type(exc).__name__}"


def load_split(root: str | Path, split: str, build: bool = True, progress: bool = True) -> SplitArrays:
    """Load a split from the cache, building the cache first when needed.

    A damaged cache file is decoded again once, with a warning (:class:`DatasetError` if that is not
    allowed, ``build=False``, or does not help).
    """
    split = layout.normalize_split(split)
    path = cache_path(root, split)
    if not path.exists():
        if not build:
            raise FileNotFoundError(path)
        build_split(root, split, progress=progress)
    got = _read(path, split)
    if isinstance(got, SplitArrays):
        return got
    if not build:
        raise DatasetError(f"the dataset cache {path} is damaged ({got}); delete it to decode the split again")
    warnings.warn(f"the dataset cache {path} is damaged ({got}); decoding the {split} split again", stacklevel=2)
    for stale in (path, digest_path(path)):
        stale.unlink(missing_ok=True)
    build_split(root, split, progress=progress)
    got = _read(path, split)
    if isinstance(got, SplitArrays):
        return got
    raise DatasetError(f"the dataset cache {path} is damaged again after decoding ({got})")
