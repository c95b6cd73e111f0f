"""The shipped propagating head run by ONNX Runtime: ``plan``'s last resort on large grids, no torch needed.

The head (:mod:`ndrql.model.propagator`, trained by ``studies/propagate/train.py``) ships as
``ndrql/data/propagator.onnx`` (:data:`~ndrql.model.propagator.CHUNK` iterations per call), exported from
``propagator.pt`` beside it; ``propagator.json`` records both files' SHA-256 and the largest difference from torch
measured at export (``python tools/export_propagator.py``). A graph whose record does not match is not used.

:func:`propagate` runs it on a planning grid for about one iteration per cell of the grid's longer side
(:func:`iterations`) and returns, per cell, the probability of "on some 4-connected shortest route from start to
goal".
"""

from __future__ import annotations

import json
import math
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ndrql.io import file_digest
from ndrql.model.onnx_backend import open_session
from ndrql.model.shipped import data_dir

Point = tuple[int, int]

#: Iterations per cell of the grid's longer side (the rule's "one iteration per cell of the side").
PER_SIDE = 1.0
#: Fewest iterations on any grid.
MIN_ITERS = 8


def graph_file() -> Path:
    return data_dir() / "propagator.onnx"


def record_file() -> Path:
    return data_dir() / "propagator.json"


def read_record() -> dict[str, Any] | None:
    """The export record (``weights_sha256``, ``onnx_sha256``, ``chunk``, ``width``, ``max_difference``), or None."""
    try:
        record = json.loads(record_file().read_text())
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) else None


@lru_cache(maxsize=1)
def available() -> bool:
    """True when the shipped graph is present and matches its record (checked once per process)."""
    record = read_record()
    graph = graph_file()
    return record is not None and graph.is_file() and file_digest(graph) == record.get("onnx_sha256")


def iterations(shape: tuple[int, ...], chunk: int) -> int:
    """Iterations on a grid of ``shape``: :data:`PER_SIDE` per cell of its longer side, at least :data:`MIN_ITERS`,
    rounded up to whole calls of ``chunk``."""
    want = max(MIN_ITERS, math.ceil(PER_SIDE * max(shape)))
    return chunk * math.ceil(want / chunk)


@lru_cache(maxsize=4)
def _session(threads: int) -> Any:
    return open_session(graph_file(), threads)


def head_input(blocked: np.ndarray, start: Point, goal: Point) -> np.ndarray:
    """``(1, 3, rows, cols)`` float32: free cells, the start cell, the goal cell."""
    free = ~np.asarray(blocked, bool)
    x = np.zeros((1, 3, *free.shape), np.float32)
    x[0, 0] = free
    x[0, 1][tuple(start)] = 1.0
    x[0, 2][tuple(goal)] = 1.0
    return x


def propagate(blocked: np.ndarray, start: Point, goal: Point, threads: int = 0) -> np.ndarray:
    """Per cell of the planning grid ``blocked``, the head's probability that it lies on a shortest route from
    ``start`` to ``goal`` (0 on blocked cells). Needs :func:`available`."""
    record = read_record() or {}
    chunk, width = int(record["chunk"]), int(record["width"])
    x = head_input(blocked, start, goal)
    h = np.zeros((1, width, *x.shape[2:]), np.float32)
    session = _session(int(threads))
    logit = None
    for _ in range(iterations(x.shape[2:], chunk) // chunk):
        logit, h = session.run(None, {"x": x, "h": h})
    prob = 1.0 / (1.0 + np.exp(-np.asarray(logit[0, 0], np.float64)))
    return np.where(np.asarray(blocked, bool), 0.0, prob)
