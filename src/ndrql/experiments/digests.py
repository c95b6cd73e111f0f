"""The digests that key stored results: a task's fingerprint and a digest of arrays.

Both are the first 16 hex digits of a SHA-256 (:func:`ndrql.io.data_digest`). A stored task whose
fingerprint differs from the one computed now is recomputed (:mod:`ndrql.experiments.sweep`), so what
goes into a fingerprint decides when results are reused; a change here recomputes every stored task.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from ndrql.io import data_digest


def fingerprint(*parts: Any) -> str:
    """Short, stable digest of JSON-serialisable ``parts`` (dataclasses via ``vars``)."""
    blob = json.dumps(parts, sort_keys=True, default=lambda o: vars(o) if hasattr(o, "__dict__") else repr(o))
    return data_digest(blob)[:16]


def array_digest(*arrays: np.ndarray) -> str:
    """Short digest of the bytes of ``arrays`` (each in C order, one after the other)."""
    return data_digest(*arrays)[:16]
