"""Reader for the path-planning dataset in its original layout (see ``data/README.md``).

Every anomaly of the upstream files is handled here, once: x is the row; TRAIN sample ``i`` uses
map ``i % 4000``; UNSEEN 900..1199 have 256x256 maps (resized like the generator did, cv2-style
bilinear then ``> 127``), reversed waypoints, and broken region labels that are regenerated from the
guideline by the generator's 30x30 dilation (:func:`ndrql.synth.labels.dilate_region`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ndrql.errors import DatasetError
from ndrql.maps.grid import MODEL_SIDE
from ndrql.synth.labels import dilate_region  # the label definition's one home (re-exported here)

#: Split name on the CLI -> folder inside the dataset root.
SPLITS: dict[str, str] = {"train": "TRAIN", "seen": "TEST/SEEN", "unseen": "TEST/UNSEEN"}
#: Number of samples per split.
SPLIT_SIZES: dict[str, int] = {"train": 12000, "seen": 1200, "unseen": 1200}
#: Category names per split, by index block (data/README.md).
CATEGORIES: dict[str, tuple[str, ...]] = {
    "train": ("GAPS", "BUGTRAP&BLOCKS", "BLOCKS", "GAPS&BLOCKS"),
    "seen": ("GAPS", "BUGTRAP&BLOCKS", "BLOCKS", "GAPS&BLOCKS"),
    "unseen": ("BUGTRAP", "BUGTRAPS", "MAZE", "NARROW PASSAGE"),
}
MAP_DIR = "MAP [ORIGINAL]"
POINTS_DIR = "COORDINATE [TARGET&GOAL]"
WAYPOINTS_DIR = "COORDINATE [SIGNIFICANT WAYPOINT]"
GUIDE_DIR = "PATH [2PIXEL]"
REGION_DIR = "PATH [30PIXEL]"
COST_DIR = "PATH [COST]"


@dataclass(frozen=True)
class Sample:
    """One dataset sample; all arrays 201x201 bool, points (row, col)."""

    split: str
    index: int
    map: np.ndarray  # True = obstacle
    start: tuple[int, int]
    goal: tuple[int, int]
    waypoints: np.ndarray  # (K, 2) int, (row, col), start -> goal
    guideline: np.ndarray  # PATH [2PIXEL] >= 128
    region: np.ndarray  # PATH [30PIXEL] >= 128, regenerated where broken upstream
    region_original: np.ndarray | None  # the upstream region label when it was replaced, else None
    cost: float  # RRT* c_best from PATH [COST]
    category: str
    map_index: int


def normalize_split(split: str) -> str:
    """Map ``train|seen|unseen`` (or the folder names) to the canonical short name."""
    key = split.strip().lower().replace("test/", "")
    if key not in SPLITS:
        raise DatasetError(f"unknown split {split!r}; valid: {', '.join(SPLITS)}")
    return key


def map_index(split: str, index: int) -> int:
    """Index of the map file used by a sample: TRAIN reuses its 4000 maps (``i % 4000``)."""
    return index % 4000 if normalize_split(split) == "train" else index


def category(split: str, index: int) -> str:
    """Category of a sample, from its index block (``(i % 4000) // 1000`` or ``i // 300``)."""
    split = normalize_split(split)
    block = (index % 4000) // 1000 if split == "train" else index // 300
    return CATEGORIES[split][block]


def check_root(root: str | Path) -> Path:
    """Return the dataset root as a Path, or raise DatasetError saying what is missing."""
    root = Path(root)
    if not root.is_dir():
        raise DatasetError(f"dataset directory not found: {root}")
    for folder in SPLITS.values():
        if not (root / folder / MAP_DIR).is_dir():
            raise DatasetError(f"{root} does not look like the path-planning dataset: missing '{folder}/{MAP_DIR}'")
    return root


def read_gray(path: Path) -> np.ndarray:
    """Decode an image file to a uint8 grayscale array, with a DatasetError on failure."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as img:
            return np.asarray(img.convert("L"))
    except FileNotFoundError:
        raise DatasetError(f"missing dataset file: {path}") from None
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise DatasetError(f"cannot decode image {path}: {exc}") from None


def read_ints(path: Path) -> list[int]:
    """Read whitespace/comma separated integers from a coordinate file."""
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise DatasetError(f"missing dataset file: {path}") from None
    try:
        return [int(t) for t in text.replace(",", " ").split()]
    except ValueError:
        raise DatasetError(f"malformed coordinate file: {path}") from None


def resize_bilinear_cv2(img: np.ndarray, height: int, width: int) -> np.ndarray:
    """Bilinear uint8 resize reproducing ``cv2.resize(img, (width, height))`` (INTER_LINEAR).

    OpenCV uses half-pixel centres and 11-bit fixed-point weights for 8-bit images; this copies that
    arithmetic so the 256 px UNSEEN maps binarize exactly as the dataset generator saw them.
    """
    src = np.asarray(img, dtype=np.int64)
    sh, sw = src.shape

    def taps(dst: int, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        scale = size / dst
        f = (np.arange(dst, dtype=np.float64) + 0.5) * scale - 0.5
        i0 = np.floor(f).astype(np.int64)
        frac = f - i0
        frac[i0 < 0] = 0.0
        i0[i0 < 0] = 0
        over = i0 >= size - 1
        frac[over] = 0.0
        i0[over] = size - 1
        i1 = np.minimum(i0 + 1, size - 1)
        w1 = np.rint(frac * 2048).astype(np.int64)
        return i0, i1, w1

    y0, y1, wy1 = taps(height, sh)
    x0, x1, wx1 = taps(width, sw)
    wx0, wy0 = 2048 - wx1, 2048 - wy1
    rows = src[:, x0] * wx0 + src[:, x1] * wx1  # horizontal pass, scaled by 2048
    top, bottom = rows[y0], rows[y1]
    out = (((wy0[:, None] * (top >> 4)) >> 16) + ((wy1[:, None] * (bottom >> 4)) >> 16) + 2) >> 2
    return np.clip(out, 0, 255).astype(np.uint8)


def load_map(root: str | Path, split: str, index: int) -> np.ndarray:
    """The 201x201 obstacle mask (True = obstacle) a sample was planned on."""
    split = normalize_split(split)
    check_index(split, index)
    gray = read_gray(Path(root) / SPLITS[split] / MAP_DIR / f"{map_index(split, index)}.jpg")
    if gray.shape != (MODEL_SIDE, MODEL_SIDE):  # UNSEEN 900..1199 are 256x256
        gray = resize_bilinear_cv2(gray, MODEL_SIDE, MODEL_SIDE)
        return gray <= 127
    return gray < 128


def load_points(root: str | Path, split: str, index: int) -> tuple[tuple[int, int], tuple[int, int]]:
    """Start and goal as (row, col): the file's x is the row."""
    split = normalize_split(split)
    check_index(split, index)
    path = Path(root) / SPLITS[split] / POINTS_DIR / f"{index}.txt"
    vals = read_ints(path)
    if len(vals) != 4:
        raise DatasetError(f"expected 4 integers in {path}, found {len(vals)}")
    return (vals[0], vals[1]), (vals[2], vals[3])


def load_waypoints(root: str | Path, split: str, index: int) -> np.ndarray:
    """RRT* waypoints (K, 2) as (row, col) from start to goal (UNSEEN 900..1199 reordered)."""
    split = normalize_split(split)
    path = Path(root) / SPLITS[split] / WAYPOINTS_DIR / f"{index}.txt"
    vals = read_ints(path)
    if len(vals) < 4 or len(vals) % 2:
        raise DatasetError(f"malformed waypoint file: {path}")
    wp = np.asarray(vals, dtype=np.int64).reshape(-1, 2)
    _, goal = load_points(root, split, index)
    if tuple(wp[-1]) != tuple(goal):  # stored as [start, goal, parent(goal), ..., next-to-start]
        wp = np.concatenate([wp[:1], wp[1:][::-1]])
    return wp


def count_samples(root: str | Path, split: str) -> int:
    """Samples present in a split (the full dataset has SPLIT_SIZES; test fixtures have fewer)."""
    folder = Path(root) / SPLITS[normalize_split(split)] / POINTS_DIR
    if not folder.is_dir():
        raise DatasetError(f"dataset folder not found: {folder}")
    return sum(1 for p in folder.iterdir() if p.suffix == ".txt" and p.stem.isdigit())


def check_index(split: str, index: int) -> None:
    """Raise DatasetError when ``index`` is outside the split."""
    n = SPLIT_SIZES[split]
    if not 0 <= index < n:
        raise DatasetError(f"sample index {index} out of range for split {split!r} (0..{n - 1})")


def load_sample(root: str | Path, split: str, index: int) -> Sample:
    """Load one sample with every upstream anomaly handled (see module docstring)."""
    split = normalize_split(split)
    check_index(split, index)
    base = Path(root) / SPLITS[split]
    if not base.is_dir():
        raise DatasetError(f"dataset split folder not found: {base}")
    obstacles = load_map(root, split, index)
    start, goal = load_points(root, split, index)
    guideline = read_gray(base / GUIDE_DIR / f"{index}.jpg") >= 128
    region_raw = read_gray(base / REGION_DIR / f"{index}.jpg") >= 128
    broken = split == "unseen" and index >= 900
    if broken or region_raw.shape != (MODEL_SIDE, MODEL_SIDE):
        region, original = dilate_region(guideline), region_raw
    else:
        region, original = region_raw, None
    cost_path = base / COST_DIR / f"{index}.txt"
    try:
        cost = float(cost_path.read_text())
    except FileNotFoundError:
        raise DatasetError(f"missing dataset file: {cost_path}") from None
    except ValueError:
        raise DatasetError(f"malformed cost file: {cost_path}") from None
    return Sample(
        split=split,
        index=index,
        map=obstacles,
        start=start,
        goal=goal,
        waypoints=load_waypoints(root, split, index),
        guideline=guideline,
        region=region,
        region_original=original,
        cost=cost,
        category=category(split, index),
        map_index=map_index(split, index),
    )


#: Environment variable naming the dataset root (the folder holding ``TRAIN`` and ``TEST``).
DATASET_ENV = "NDRQL_DATASET"


def default_root() -> Path | None:
    """The dataset root used when ``--data`` is not given, or ``None``.

    ``$NDRQL_DATASET`` when set; else the first ``path-planning-dataset`` folder (as ``git clone``
    names it) found in the working directory, in ``data/`` below it, or in ``../shared/data/`` beside
    it or beside the repository.
    """
    env = os.environ.get(DATASET_ENV)
    if env:
        return Path(env).expanduser().resolve()
    here = Path(__file__).resolve()
    name = "path-planning-dataset"
    candidates = [Path.cwd() / name, Path.cwd() / "data" / name, Path.cwd() / "../shared/data" / name]
    candidates += [p / "../shared/data" / name for p in here.parents[:5]]
    for cand in candidates:
        if (cand / "TRAIN").is_dir():
            return cand.resolve()
    return None


def resolve_root(root: str | Path | None) -> Path:
    """The dataset root (given, ``$NDRQL_DATASET``, or beside the repository)."""
    if root is None:
        root = os.environ.get(DATASET_ENV) or default_root()
    if root is None:
        raise DatasetError("dataset not found; pass --data DIR (the path-planning-dataset folder)")
    root = Path(root)
    if not (root / "TEST" / "SEEN").is_dir():
        raise DatasetError(f"no TEST/SEEN in {root}; pass --data DIR (the path-planning-dataset folder)")
    return root
