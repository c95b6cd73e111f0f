"""Map readers: plain images, ROS ``map_server`` YAML, MovingAI ``.map``/``.scen``, ``.npy``.

Every reader returns a :class:`~ndrql.maps.grid.GridMap` (``True`` = obstacle, ``(row, col)``) and
turns any problem with the file into :class:`~ndrql.errors.MapFormatError` with a one-line message.
:func:`load_map` picks the reader from the file extension. The dataset layout has its own reader,
:func:`ndrql.dataset.layout.load_sample`.

Hostile files cost memory in proportion to their size, never more: a map larger than ``max_pixels``
is refused from its header before any pixel is decoded, and error messages never echo a value from
the file unbounded (:func:`ndrql.errors.brief`; a 600-byte YAML alias bomb stays 600 bytes).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ndrql.errors import MapFormatError, brief
from ndrql.io.readset import note_input
from ndrql.limits import MAX_GRID_SIZE
from ndrql.maps.grid import GridMap
from ndrql.maps.ros_yaml import YAML_SUFFIXES, map_files, ros_doc, ros_image  # noqa: F401 (map_files: re-exported)

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".pgm", ".ppm", ".pbm", ".bmp", ".tif", ".tiff")
MOVINGAI_FREE = frozenset(".GS")
MOVINGAI_BLOCKED = frozenset("@OTW")
ROS_MODES = ("trinary", "scale", "raw")
ROS_REQUIRED_KEYS = ("image", "resolution", "origin", "occupied_thresh", "free_thresh")
#: Largest map read by default (pixels): 4096 x 4096. Raise it with ``max_pixels`` (``--max-pixels``).
MAX_MAP_PIXELS = 4096 * 4096
#: Most one side of a map may exceed the other (times): a safe grid's cells are at most twice the
#: shorter side, and at most :data:`ndrql.limits.MAX_GRID_SIZE` (1024) cells fit on the longer one.
MAX_ASPECT = 2 * MAX_GRID_SIZE


def check_pixels(height: int, width: int, max_pixels: int | None, path: Path) -> None:
    """:class:`MapFormatError` when a ``height`` x ``width`` map exceeds ``max_pixels`` (``None``: no limit)
    or is too thin to plan on (one side more than :data:`MAX_ASPECT` times the other), from the header."""
    if max_pixels is not None and height * width > max_pixels:
        raise MapFormatError(
            f"{path}: map is {height}x{width} = {height * width:,} pixels, more than the limit of {max_pixels:,}; "
            f"crop or downscale it, or raise --max-pixels")
    if max(height, width) > MAX_ASPECT * max(1, min(height, width)):
        raise MapFormatError(f"{path}: map is {height}x{width}, one side more than {MAX_ASPECT:,} times the other: "
                             f"too thin to plan on; crop it")


def _require_file(path: Path, what: str = "map file") -> None:
    if not path.is_file():
        raise MapFormatError(f"not a file: {path}" if path.exists() else f"{what} not found: {path}")
    note_input(path, "the map file")


def _decode_image(path: Path, max_pixels: int | None = MAX_MAP_PIXELS) -> np.ndarray:
    """Decode an image to an array of shape (H, W) or (H, W, C) on the 8-bit scale 0..255.

    One rule per pixel, whatever the other pixels hold: 8-bit values as they are; integer images of
    more bits (16-bit PNG, TIFF) on 0..65535, scaled by 255 / 65535; float images on 0..1 (0 black,
    1 white), scaled by 255. NaN or infinite values, and values outside the scale, are refused.
    Alpha is kept as the last channel for ROS ``scale`` mode. The size is checked against
    ``max_pixels`` from the header, before decoding.
    """
    import warnings

    from PIL import Image

    _require_file(path)
    try:
        with warnings.catch_warnings():  # the size check below replaces Pillow's bomb warning
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path) as img:
                check_pixels(img.height, img.width, max_pixels, path)
                img.load()
                mode = img.mode
                if mode in ("1", "P", "CMYK", "YCbCr", "LAB", "HSV", "PA"):
                    img = img.convert("RGBA" if "transparency" in img.info or mode == "PA" else "RGB")
                    mode = img.mode
                arr = np.asarray(img)
    except MapFormatError:
        raise
    except Image.DecompressionBombError:
        raise MapFormatError(f"map {path} has more pixels than Pillow will decode; crop or downscale it") from None
    except Exception as exc:  # Pillow raises many types on corrupt input (OSError, ValueError, SyntaxError, ...)
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise MapFormatError(f"cannot read image {path}: {reason}") from exc
    if arr.ndim not in (2, 3) or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise MapFormatError(f"cannot read image {path}: unexpected shape {arr.shape}")
    return _to_8bit_scale(arr, path)


def _to_8bit_scale(arr: np.ndarray, path: Path) -> np.ndarray:
    """The pixel rule of :func:`_decode_image`: 0..255 (8-bit images kept as uint8), each pixel by itself."""
    if arr.dtype.kind == "f":
        if not np.isfinite(arr).all():
            raise MapFormatError(f"image {path} has NaN or infinite pixels; give every pixel a value")
        if arr.min(initial=0.0) < 0 or arr.max(initial=0.0) > 1:
            raise MapFormatError(f"float image {path} has values outside 0..1 (0 black, 1 white): "
                                 f"{float(arr.min()):g}..{float(arr.max()):g}; scale it to 0..1 or save it as 8-bit")
        return arr.astype(np.float64) * 255.0
    if arr.dtype.kind in "iu" and arr.dtype.itemsize > 1:
        lo, hi = int(arr.min(initial=0)), int(arr.max(initial=0))
        if lo < 0 or hi > 65535:
            raise MapFormatError(f"image {path} has integer values outside 0..65535 ({lo}..{hi}); save it as 8 or 16 bit")
        if 0 < hi <= 255:
            import warnings

            warnings.warn(f"{path} is a 16-bit image whose values are all <= 255: read on the 16-bit scale "
                          f"(0..65535), every pixel is dark; save it as 8-bit if 255 means white", stacklevel=3)
        return arr.astype(np.float64) * (255.0 / 65535.0)
    return arr


def _gray(arr: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Split a decoded image into gray (mean of the colour channels) and alpha (or ``None``)."""
    if arr.ndim == 2:
        return arr.astype(np.float64), None
    channels = arr.shape[2]
    if channels == 2:  # LA
        return arr[..., 0].astype(np.float64), arr[..., 1]
    if channels == 4:  # RGBA
        return arr[..., :3].mean(axis=2, dtype=np.float64), arr[..., 3]
    return arr[..., :3].mean(axis=2, dtype=np.float64), None


def read_image(path: str | Path, invert: bool = False, threshold: float = 128,
               max_pixels: int | None = MAX_MAP_PIXELS) -> GridMap:
    """Read a plain image map: dark pixels (gray < ``threshold``) are obstacles; ``invert`` flips that.

    Colour images use the mean of their channels; transparency is ignored.
    """
    path = Path(path)
    gray, _ = _gray(_decode_image(path, max_pixels))
    obstacles = gray < threshold
    if invert:
        obstacles = ~obstacles
    return GridMap(obstacles, source=str(path))


def _number(value: object) -> float | None:
    """``value`` as a float (numbers and numeric strings; a huge integer is infinite), else ``None``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        return None
    try:
        return float(value[:64] if isinstance(value, str) else value)
    except OverflowError:
        return math.inf
    except ValueError:
        return None


def _ros_float(doc: dict, key: str, path: Path) -> float:
    value = _number(doc[key])
    if value is None:
        raise MapFormatError(f"ROS map {path}: '{key}' must be a number, got {brief(doc[key])}")
    if not math.isfinite(value):
        raise MapFormatError(f"ROS map {path}: '{key}' must be finite, got {brief(doc[key])}")
    return value


def read_ros_yaml(path: str | Path, crop: bool = False, max_pixels: int | None = MAX_MAP_PIXELS,
                  unknown_free: bool = False) -> GridMap:
    """Read a ROS ``map_server`` map (YAML + image), as ``map_server`` interprets it.

    ``p = (255 - v) / 255`` (``v / 255`` when ``negate``) with ``v`` the mean of the colour channels;
    ``trinary``: occupied when ``p > occupied_thresh``, free when ``p < free_thresh``, else unknown;
    ``scale``: as trinary, but in-between values are occupancy ``(p - free) / (occ - free)``, or
    unknown when the pixel is not opaque; ``raw``: ``v`` is the occupancy in percent (> 100 = unknown).
    Unknown cells (unless ``unknown_free``) and cells with occupancy >= 50 % are obstacles. ``crop`` keeps only the
    bounding box of the known cells (the origin moves with it). Row 0 is the image's top row; the
    YAML origin is the pose of the lower-left pixel, kept as given.
    """
    path = Path(path)
    _require_file(path)
    doc = ros_doc(path)
    missing = [k for k in ROS_REQUIRED_KEYS if k not in doc]
    if missing:
        raise MapFormatError(f"ROS map {path}: missing key(s) {', '.join(missing)}")
    resolution = _ros_float(doc, "resolution", path)
    if not 1e-6 <= resolution <= 1e6:  # metres per pixel: a micrometre to a thousand kilometres
        raise MapFormatError(f"ROS map {path}: 'resolution' must be positive, in [1e-06, 1e+06] m, got {resolution:g}")
    occ = _ros_float(doc, "occupied_thresh", path)
    free = _ros_float(doc, "free_thresh", path)
    if not (0.0 <= free <= occ <= 1.0):
        raise MapFormatError(f"ROS map {path}: need 0 <= free_thresh <= occupied_thresh <= 1, got {free}, {occ}")
    origin = doc["origin"]
    if not isinstance(origin, (list, tuple)) or len(origin) not in (2, 3):
        raise MapFormatError(f"ROS map {path}: 'origin' must be [x, y, yaw], got {brief(origin)}")
    numbers = [_number(v) for v in origin]
    for v, n in zip(origin, numbers):
        if n is None or not math.isfinite(n):
            raise MapFormatError(f"ROS map {path}: 'origin' must hold finite numbers, got {brief(v)}")
    origin = numbers + ([0.0] if len(origin) == 2 else [])
    negate = doc.get("negate", 0)
    if isinstance(negate, (list, dict)) or negate not in (0, 1, True, False):
        raise MapFormatError(f"ROS map {path}: 'negate' must be 0 or 1, got {brief(negate)}")
    mode = doc.get("mode", "trinary")
    if not isinstance(mode, str):
        raise MapFormatError(f"ROS map {path}: 'mode' must be one of {', '.join(ROS_MODES)}, got {brief(mode)}")
    if mode not in ROS_MODES:
        raise MapFormatError(f"ROS map {path}: unknown mode {brief(mode)}; valid: {', '.join(ROS_MODES)}")
    image_path = ros_image(path, doc)
    if not image_path.exists():
        raise MapFormatError(f"ROS map {path}: image file not found: {image_path}")

    gray, alpha = _gray(_decode_image(image_path, max_pixels))
    if mode == "raw":
        unknown = gray > 100
        obstacles = (gray >= 50) if unknown_free else unknown | (gray >= 50)
    else:
        p = gray / 255.0 if negate else (255.0 - gray) / 255.0
        occupied = p > occ
        unknown = ~occupied & ~(p < free)
        if mode == "scale":  # in-between pixels are known occupancies unless transparent (map_server)
            in_between = unknown
            unknown = in_between & (alpha < 255) if alpha is not None else np.zeros_like(in_between)
            span = occ - free
            level = (p - free) / span if span > 0 else np.ones_like(p)
            occupied = occupied | (in_between & ~unknown & (level >= 0.5))
        obstacles = occupied if unknown_free else occupied | unknown

    if crop:
        known = ~unknown
        if not known.any():
            raise MapFormatError(f"ROS map {path}: crop requested but every cell is unknown")
        rows = np.flatnonzero(known.any(axis=1))
        cols = np.flatnonzero(known.any(axis=0))
        r0, r1, c0, c1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
        height = obstacles.shape[0]
        # the new lower-left pixel is (r1 - 1, c0): shift by c0 columns and (height - r1) rows, in the map frame
        dx, dy = c0 * resolution, (height - r1) * resolution
        yaw = origin[2]
        origin = [
            origin[0] + dx * math.cos(yaw) - dy * math.sin(yaw),
            origin[1] + dx * math.sin(yaw) + dy * math.cos(yaw),
            yaw,
        ]
        obstacles = obstacles[r0:r1, c0:c1]
    return GridMap(obstacles, resolution=resolution, origin=tuple(origin), source=str(path))


def _read_text(path: Path, what: str) -> str:
    _require_file(path, f"{what} file")
    try:
        return path.read_bytes().decode("ascii")
    except UnicodeDecodeError:
        raise MapFormatError(f"{what} {path}: not an ASCII text file") from None


def read_movingai_map(path: str | Path, max_pixels: int | None = MAX_MAP_PIXELS) -> GridMap:
    """Read a MovingAI ``.map``: header ``type octile``, ``height H``, ``width W``, ``map``, then H rows.

    ``.`` ``G`` ``S`` are free; ``@`` ``O`` ``T`` ``W`` are blocked. Row 0 is the first map line, column 0
    its first character (MovingAI's y and x).
    """
    path = Path(path)
    lines = _read_text(path, "MovingAI map").splitlines()
    header: dict[str, str] = {}
    i = 0
    while i < len(lines):
        line = lines[i].strip()
        i += 1
        if not line:
            continue
        if line.lower() == "map":
            break
        parts = line.split()
        if len(parts) != 2 or parts[0].lower() not in ("type", "height", "width"):
            raise MapFormatError(f"MovingAI map {path}: bad header line {i}: {line[:40]!r}")
        header[parts[0].lower()] = parts[1]
    else:
        raise MapFormatError(f"MovingAI map {path}: bad header, no 'map' line")
    missing = [k for k in ("type", "height", "width") if k not in header]
    if missing:
        raise MapFormatError(f"MovingAI map {path}: bad header, missing {', '.join(missing)}")
    if header["type"].lower() != "octile":
        raise MapFormatError(f"MovingAI map {path}: bad header, type {header['type']!r} (only 'octile' is supported)")
    try:
        height, width = int(header["height"]), int(header["width"])
    except ValueError:
        raise MapFormatError(f"MovingAI map {path}: bad header, height/width must be integers") from None
    if height < 1 or width < 1:
        raise MapFormatError(f"MovingAI map {path}: bad header, height and width must be positive")
    check_pixels(height, width, max_pixels, path)
    rows = [ln.rstrip("\r") for ln in lines[i:]]
    while rows and not rows[-1].strip():
        rows.pop()
    if len(rows) != height:
        raise MapFormatError(f"MovingAI map {path}: header says height {height}, found {len(rows)} rows")
    for r, row in enumerate(rows):  # validate everything before allocating anything
        if len(row) != width:
            raise MapFormatError(f"MovingAI map {path}: row {r} has {len(row)} cells, header says width {width}")
        bad = set(row) - MOVINGAI_FREE - MOVINGAI_BLOCKED
        if bad:
            raise MapFormatError(f"MovingAI map {path}: row {r} has unknown terrain {''.join(sorted(bad))[:10]!r}")
    codes = np.frombuffer("".join(rows).encode("ascii"), dtype=np.uint8).reshape(height, width)
    obstacles = np.isin(codes, np.frombuffer("".join(sorted(MOVINGAI_BLOCKED)).encode("ascii"), dtype=np.uint8))
    return GridMap(obstacles, source=str(path))


@dataclass(frozen=True)
class Scenario:
    """One MovingAI scenario line, converted to ``(row, col)`` (MovingAI x = column, y = row)."""

    bucket: int
    map: str
    """The map file name as written in the ``.scen`` (relative to the benchmark's map folder)."""
    width: int
    height: int
    start: tuple[int, int]
    goal: tuple[int, int]
    optimal_length: float
    """Octile length of an optimal path without corner cutting."""


def read_movingai_scen(path: str | Path) -> list[Scenario]:
    """Read a MovingAI ``.scen``: an optional ``version`` line, then one tab-separated scenario per line:
    ``bucket map width height start_x start_y goal_x goal_y optimal_length``.
    """
    path = Path(path)
    lines = _read_text(path, "MovingAI scenario").splitlines()
    out: list[Scenario] = []
    start_line = 0
    if lines and lines[0].strip().lower().startswith("version"):
        parts = lines[0].split()
        if len(parts) != 2:
            raise MapFormatError(f"MovingAI scenario {path}: bad version line {lines[0][:40]!r}")
        try:
            float(parts[1])
        except ValueError:
            raise MapFormatError(f"MovingAI scenario {path}: bad version line {lines[0][:40]!r}") from None
        start_line = 1
    for n, line in enumerate(lines[start_line:], start=start_line + 1):
        if not line.strip():
            continue
        parts = line.rstrip("\r\n").split("\t") if "\t" in line else line.split()
        parts = [p.strip() for p in parts]
        if len(parts) != 9:
            raise MapFormatError(f"MovingAI scenario {path}: line {n} has {len(parts)} fields, expected 9")
        try:
            bucket, width, height, sx, sy, gx, gy = (int(parts[k]) for k in (0, 2, 3, 4, 5, 6, 7))
            optimal = float(parts[8])
        except ValueError:
            raise MapFormatError(f"MovingAI scenario {path}: line {n}: non-numeric field") from None
        if width < 1 or height < 1 or not math.isfinite(optimal) or optimal < 0:
            raise MapFormatError(f"MovingAI scenario {path}: line {n}: bad size or length")
        for x, y in ((sx, sy), (gx, gy)):
            if not (0 <= x < width and 0 <= y < height):
                raise MapFormatError(f"MovingAI scenario {path}: line {n}: point ({x}, {y}) outside {width}x{height}")
        out.append(Scenario(bucket, parts[1], width, height, (sy, sx), (gy, gx), optimal))
    return out


def read_npy(path: str | Path, max_pixels: int | None = MAX_MAP_PIXELS) -> GridMap:
    """Read a 2-D ``.npy`` array: non-zero (``True``) = obstacle. Pickled objects are refused.

    The file is memory-mapped first, so shape, dtype and size are checked before any data is read.
    """
    path = Path(path)
    _require_file(path)
    try:
        arr = np.load(path, mmap_mode="r", allow_pickle=False)
    except Exception as exc:  # numpy raises ValueError, OSError, EOFError, ... on corrupt files
        reason = str(exc).splitlines()[0][:200] if str(exc) else type(exc).__name__
        raise MapFormatError(f"cannot read .npy map {path}: {reason}") from None
    if not isinstance(arr, np.ndarray) or arr.ndim != 2 or 0 in arr.shape:
        raise MapFormatError(f".npy map {path}: expected a non-empty 2-D array, got shape {getattr(arr, 'shape', None)}")
    if arr.dtype.kind not in "biuf":
        raise MapFormatError(f".npy map {path}: expected a boolean or numeric array, got dtype {arr.dtype}")
    check_pixels(arr.shape[0], arr.shape[1], max_pixels, path)
    arr = np.array(arr)
    if arr.dtype.kind == "f" and not np.isfinite(arr).all():
        raise MapFormatError(f".npy map {path}: contains NaN or infinite values")
    return GridMap(arr != 0, source=str(path))


def load_map(path: str | Path, *, invert: bool = False, threshold: float = 128, crop: bool = False,
             max_pixels: int | None = MAX_MAP_PIXELS) -> GridMap:
    """Load a map, choosing the reader by extension (image, ROS YAML, MovingAI ``.map``, ``.npy``).

    ``invert`` and ``threshold`` apply to plain images, ``crop`` to ROS maps; a map of more than
    ``max_pixels`` pixels (``None``: no limit) is refused before it is decoded.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise MapFormatError(f"a map is a file path, got {brief(path)}")
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in IMAGE_SUFFIXES:
        return read_image(path, invert=invert, threshold=threshold, max_pixels=max_pixels)
    if suffix in YAML_SUFFIXES:
        return read_ros_yaml(path, crop=crop, max_pixels=max_pixels)
    if suffix == ".map":
        return read_movingai_map(path, max_pixels=max_pixels)
    if suffix == ".npy":
        return read_npy(path, max_pixels=max_pixels)
    supported = ", ".join(IMAGE_SUFFIXES + YAML_SUFFIXES + (".map", ".npy"))
    raise MapFormatError(f"unsupported map format {suffix or '(no extension)'!r} for {path}; supported: {supported}")
