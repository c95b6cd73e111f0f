"""JSON, NPZ and figures written through the atomic writer, and the digests that name inputs and caches."""

from __future__ import annotations

import hashlib
import json
import math
import os
from pathlib import Path
from typing import Any, Mapping

from ndrql.errors import OutputError
from ndrql.io.atomic import atomic_write, write_text


def to_jsonable(obj: Any, *, strict: bool = True) -> Any:
    """``obj`` with numpy arrays and scalars, tuples and paths turned into JSON types.

    ``strict``: NaN and infinities become ``None`` (standard JSON); otherwise they are kept (Python's
    ``NaN``/``Infinity`` extension, which :mod:`json` reads back exactly).
    """
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v, strict=strict) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v, strict=strict) for v in obj]
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if hasattr(obj, "tolist") and hasattr(obj, "dtype"):  # numpy array or scalar
        return to_jsonable(obj.tolist(), strict=strict)
    if strict and isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def json_text(obj: Any, *, indent: int | None = 2, strict: bool = True) -> str:
    """``obj`` as JSON text (:func:`to_jsonable`), indented or compact (``indent=None``), no final newline.

    ``strict=False`` keeps NaN and infinities so that the text reads back to the same numbers.
    """
    separators = (",", ":") if indent is None else None
    return json.dumps(to_jsonable(obj, strict=strict), indent=indent, separators=separators, allow_nan=not strict)


def write_json(path: str | os.PathLike, obj: Any, *, indent: int | None = 2, strict: bool = True) -> Path:
    """Write ``obj`` as JSON (:func:`json_text`) and a newline."""
    return write_text(path, json_text(obj, indent=indent, strict=strict) + "\n")


def save_npz(path: str | os.PathLike, arrays: Mapping[str, Any] | None = None, *, compressed: bool = True,
             **named: Any) -> Path:
    """Write arrays (a mapping and/or keywords) as an ``.npz`` archive, zip-compressed by default."""
    import numpy as np

    contents = {**(arrays or {}), **named}
    save = np.savez_compressed if compressed else np.savez
    return atomic_write(path, lambda fh: save(fh, **contents))


def save_figure(fig: Any, path: str | os.PathLike, **savefig_kw: Any) -> Path:
    """Save a matplotlib figure in the format of ``path``'s extension (PNG when there is none)."""
    fmt = Path(path).suffix.lstrip(".").lower() or "png"
    supported = fig.canvas.get_supported_filetypes()
    if fmt not in supported:
        raise OutputError(f"cannot save a figure as {fmt!r}; use one of {', '.join(sorted(supported))}")
    return atomic_write(path, lambda fh: fig.savefig(fh, format=fmt, **savefig_kw))


def cache_dir() -> Path:
    """Root of ndrql's local caches (``$NDRQL_CACHE`` or ``~/.cache/ndrql``): the dataset, ONNX exports and
    ONNX Runtime's optimised graphs, runs; never inside the package."""
    return Path(os.environ.get("NDRQL_CACHE", Path.home() / ".cache" / "ndrql"))


def file_digest(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes, as 64 hex digits (read in 1 MB chunks)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def data_digest(*parts: Any, algorithm: str = "sha256") -> str:
    """Hex digest of ``parts`` in order: bytes as they are, text as UTF-8, arrays as their C-order bytes.

    The one way ndrql names data by content (task fingerprints, cached predictions, study names);
    ``algorithm`` is any :mod:`hashlib` name (the dataset's map ids and cache keys use ``sha1``).
    """
    h = hashlib.new(algorithm)
    for part in parts:
        if isinstance(part, str):
            part = part.encode()
        elif not isinstance(part, (bytes, bytearray, memoryview)):
            part = part.tobytes(order="C")  # a numpy array or scalar
        h.update(part)
    return h.hexdigest()
