"""The shipped models as ONNX graphs: how ``pip install ndrql`` plans without torch.

Beside each shipped checkpoint in ``ndrql/data`` (``ndr_default.pt``, ``ndr_general.pt``) lies its
graph (``ndr_default.onnx``, ...; any input side, :mod:`ndrql.model.export`) and a small record
(``ndr_default.onnx.json``): the SHA-256 of the checkpoint it was exported from and of the graph,
and the largest difference from torch measured at export, per input side. The Predictor uses a
graph only while its record matches the checkpoint byte for byte, so a replaced checkpoint is never
paired with a stale graph; ``python tools/export_shipped_onnx.py``
(:func:`ndrql.model.export.export_shipped`) regenerates graphs and records after new weights land
(needs torch).

A companion of a shipped model (:mod:`ndrql.model.companion`, e.g. ``ndr_general_large.pt``) ships the same
way: its checkpoint, graph and record in ``ndrql/data``, named here by its file stem.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import Any

from ndrql.io import file_digest
from ndrql.model.companion import check_stem
from ndrql.model.weights import SHIPPED_WEIGHTS, shipped_weights

#: Input sides measured against torch at export: every side ``plan`` feeds a grid-mode model from
#: 128 px (a 32-cell grid) to 2048 px (512 cells, the largest `--size auto` picks), and 201 px (the map-mode input).
CHECK_SIDES: tuple[int, ...] = (128, 160, 201, 256, 320, 400, 512, 640, 800, 1024, 2048)
#: Largest |probability difference| from torch a shipped graph may show at any checked side.
TOLERANCE = 1e-4
#: Budget of all shipped weights together (checkpoints and graphs), bytes: four models of about 5.5 MB, each as
#: an fp16 checkpoint and an ONNX graph (paper, general, general's large-grid companion and, once trained, belief),
#: ~44 MB.
SHIPPED_BUDGET = 48_000_000


def data_dir() -> Path:
    """The package's data folder, where the shipped weights, graphs and records lie."""
    return shipped_weights(next(iter(SHIPPED_WEIGHTS))).parent


def shipped_file(name: str) -> Path:
    """The shipped checkpoint ``name``: ``paper``, ``general``, ``belief`` (:data:`~ndrql.model.weights.SHIPPED_WEIGHTS`) or
    the file stem of a companion in the data folder (``ndr_general_large``)."""
    if name in SHIPPED_WEIGHTS:
        return shipped_weights(name)
    return data_dir() / f"{check_stem(name)}.pt"


def graph_path(name: str) -> Path:
    """The shipped graph of the weights called ``name`` (``paper``, ``general``, a companion's stem)."""
    return shipped_file(name).with_suffix(".onnx")


def record_path(name: str) -> Path:
    """The record of the shipped graph ``name`` (digests and measured differences)."""
    return graph_path(name).with_suffix(".onnx.json")


def read_record(name: str) -> dict[str, Any] | None:
    """The record of the shipped graph ``name``, or None when it is missing or unreadable."""
    try:
        record = json.loads(record_path(name).read_text())
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) else None


def shipped_graph(weights: Path) -> Path | None:
    """The shipped graph exported from exactly the checkpoint ``weights`` (matched by SHA-256), else None.

    A shipped checkpoint whose graph is missing, stale or damaged gives a warning (the model then runs
    from an export in the cache, which needs torch)."""
    records = {name: read_record(name) for name in [*SHIPPED_WEIGHTS, *_companion_names()]}
    if not any(records.values()):
        return None
    digest = file_digest(weights)
    for name, record in records.items():
        if record is None or record.get("weights_sha256") != digest:
            continue
        graph = graph_path(name)
        if graph.is_file() and file_digest(graph) == record.get("onnx_sha256"):
            return graph
        warnings.warn(f"the shipped ONNX graph {graph} is missing or damaged; reinstall ndrql", stacklevel=3)
        return None
    for name in SHIPPED_WEIGHTS:
        if _same_file(weights, shipped_weights(name)):
            warnings.warn(f"the shipped ONNX graph of {name!r} was exported from other weights than "
                          f"{weights.name}; regenerate it with tools/export_shipped_onnx.py", stacklevel=3)
    return None


def _companion_names() -> list[str]:
    """Stems of the companions whose graph records lie in the data folder."""
    shipped = {shipped_weights(n).stem for n in SHIPPED_WEIGHTS}
    stems = (f.name[:-len(".onnx.json")] for f in data_dir().glob("*.onnx.json"))
    return sorted(s for s in stems if s not in shipped)


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve()
    except OSError:
        return False


def shipped_bytes() -> int:
    """Size of all shipped weights (checkpoints and graphs, companions' too) in ``ndrql/data``, bytes."""
    names = [*SHIPPED_WEIGHTS, *_companion_names()]
    files = [shipped_file(n) for n in names] + [graph_path(n) for n in names]
    return sum(f.stat().st_size for f in files if f.is_file())
