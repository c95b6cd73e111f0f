"""Companion weights: a second model that serves the grids a view merges.

A grid-mode model trained under a ``coarse`` view (:class:`ndrql.dataset.views.GridView`) sees a grid
above the view's limit merged into fewer cells. A model trained on such merged grids only (a
*specialist*) can ship beside it as a **companion**: the base weights' config names it in
``merged_weights`` (the file stem, e.g. ``"ndr_general_large"``), resolved in the base file's folder with
the base file's suffix (``.pt`` beside a checkpoint, ``.onnx`` beside a graph, whose metadata carries the
same config). The base keeps serving every grid the view leaves unmerged (those predictions stay bit for
bit); the companion serves every grid the view merges
(:meth:`ndrql.model.predict.Predictor.serving`), through its own view (which may differ from the base's,
e.g. ``cap:512`` beside ``coarse:128``); it must read the base's inputs: the same encoding and input mode
(:func:`check_companion`). A companion's own ``merged_weights`` is not followed.

Whatever names the weights behind a prediction names both files: :func:`weights_digest` covers the
companion, so a cache entry made with one pair is never read as another's.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Mapping

from ndrql.errors import NdrqlError
from ndrql.io import file_digest

#: The model config key naming the companion (a file stem, no folder, no suffix).
CONFIG_KEY = "merged_weights"


def check_stem(stem: str) -> str:
    """``stem`` when it is a plain file stem (no folder, no suffix, not ``.``/``..``); else one clear error."""
    if not stem or Path(stem).name != stem or stem in (".", "..") or Path(stem).suffix in (".pt", ".onnx"):
        raise NdrqlError(f"merged_weights must be a file stem in the weights' folder (e.g. ndr_general_large, no "
                         f"folder or suffix), got {stem!r}")
    return stem


def companion_path(weights: Path, config: Mapping) -> Path | None:
    """The companion named by ``config`` (the base weights ``weights``' model config): its stem in ``weights``'
    folder with ``weights``' suffix; ``None`` when the config names none or its view merges nothing
    (``native``, ``cap``)."""
    stem = config.get(CONFIG_KEY) or ""
    if not stem or not str(config.get("view") or "native").startswith(("coarse:", "walls:")):
        return None
    return Path(weights).parent / (check_stem(str(stem)) + Path(weights).suffix)


def check_companion(base: Path, companion: Path, base_seen: tuple[str, str],
                    companion_seen: tuple[str, str]) -> None:
    """One clear error unless the companion reads the base's inputs: ``(encoding, input mode)`` of each. Its
    view may differ: it sees the grids it serves (those the base's view merges) through its own view, e.g. a
    specialist trained under ``cap:512`` beside a base under ``coarse:128``."""
    for what, a, b in zip(("encoding", "input mode"), base_seen, companion_seen):
        if a != b:
            raise NdrqlError(f"the companion {companion.name} of {base.name} has {what} {b}, the base {a}; "
                             f"a companion must have the base's encoding and input mode")


def missing_companion(base: Path, companion: Path) -> NdrqlError:
    """The error for a companion file that is not there."""
    return NdrqlError(f"missing companion weights {companion} (named by merged_weights in {base.name}; they serve the "
                      f"grids its view merges): put the file beside {base.name} or export the base without "
                      f"--merged-weights")


def weights_digest(weights: Path, companion: Path | None = None) -> str:
    """SHA-256 (hex) naming the weights behind a prediction: ``weights``' own file digest when it names no
    companion, else a digest of both files' digests (a missing companion counts as ``missing``), so that
    replacing either file changes it."""
    base = file_digest(weights)
    if companion is None:
        return base
    other = file_digest(companion) if companion.is_file() else "missing"
    return hashlib.sha256(f"{base}+{CONFIG_KEY}:{companion.name}:{other}".encode()).hexdigest()

