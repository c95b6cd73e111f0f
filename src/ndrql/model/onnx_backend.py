"""ONNX Runtime backend of the Predictor: one session runs every input side, no torch needed.

Where the graph comes from (:func:`find_graph`), in this order:

- the shipped weights (``paper``, ``general``) ship their graph beside the .pt file
  (:mod:`ndrql.model.shipped`), matched by the .pt's SHA-256: nothing to export;
- an ``.onnx`` file written by ``ndrql export-onnx`` is used as it is (its metadata holds the model
  config);
- any other checkpoint is exported once, on first use, into ``$NDRQL_CACHE/onnx`` (needs torch and
  onnx: :func:`ndrql.model.export.cached_export`, handed to :func:`onnx_runner`); a cache hit needs
  neither.

Only ``onnxruntime`` is imported here; this module never imports the exporter (or torch).
"""

from __future__ import annotations

import importlib.util
import json
import warnings
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ndrql.errors import NdrqlError
from ndrql.io import file_digest
from ndrql.model.shipped import shipped_graph

#: Metadata keys of an exported graph (written by :func:`ndrql.model.export.export_onnx`).
CONFIG_KEY = "ndrql_config"
WEIGHTS_KEY = "ndrql_weights_sha256"
FORMAT_KEY = "ndrql_onnx_format"
#: Format of the graphs this version writes and reads: 2 = any input side (1 = traced at one side).
EXPORT_FORMAT = 2


def onnx_available() -> bool:
    """True when ONNX Runtime can be imported (all the ONNX backend needs to run a graph)."""
    return importlib.util.find_spec("onnxruntime") is not None


def can_export() -> bool:
    """True when torch and onnx import (needed to export a checkpoint that has no graph yet); imports torch."""
    if importlib.util.find_spec("onnx") is None:
        return False
    try:
        import torch  # noqa: F401  # lazy: torch is optional
    except ImportError:
        return False
    return True


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return (1.0 / (1.0 + np.exp(-np.asarray(x, np.float64)))).astype(np.float32)


def open_session(onnx_path: Path, threads: int = 0) -> Any:
    """An ONNX Runtime CPU session of ``onnx_path`` on ``threads`` intra-op threads (0 = ONNX Runtime's default)."""
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = max(0, threads)
    opts.inter_op_num_threads = 1
    return ort.InferenceSession(str(onnx_path), sess_options=opts, providers=["CPUExecutionProvider"])


def graph_config(session: Any, onnx_path: Path) -> dict:
    """The model config recorded in an exported graph's metadata (NdrqlError for a graph ndrql did not write)."""
    meta = session.get_modelmeta().custom_metadata_map
    if CONFIG_KEY not in meta or meta.get(FORMAT_KEY) != str(EXPORT_FORMAT):
        raise NdrqlError(f"{onnx_path} is not a graph of this ndrql version (no model config of format "
                         f"{EXPORT_FORMAT} in its metadata); export it again with `ndrql export-onnx`")
    try:
        config = json.loads(meta[CONFIG_KEY])
    except ValueError:
        config = None
    if not isinstance(config, dict):
        raise NdrqlError(f"{onnx_path}: the model config in its metadata is not a JSON mapping")
    return config


class OnnxRunner:
    """The forward pass on ONNX Runtime: one session, any batch and input side; returns probabilities."""

    name = "onnx"

    def __init__(self, onnx_path: Path, threads: int = 0):
        self.path = Path(onnx_path)
        self.session = open_session(self.path, threads)
        self.config = graph_config(self.session, self.path)
        inputs = self.session.get_inputs()
        shape = list(inputs[0].shape) if len(inputs) == 1 and inputs[0].name == "x" else None
        if shape is None or len(shape) != 4 or any(isinstance(d, int) for d in (shape[0], shape[2], shape[3])) \
                or len(self.session.get_outputs()) not in (2, 3):
            raise NdrqlError(f"{self.path} is not a graph ndrql can run (it needs one input 'x' of any batch and "
                             f"side, and 2 or 3 outputs; found {[(i.name, i.shape) for i in inputs][:3]}); export it "
                             f"again with `ndrql export-onnx`")

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """Region and guideline probabilities (B, H, W), and the raw goal-distance output (B, H, W) of a graph
        that has one (``None`` otherwise)."""
        try:
            region, guide, *dist = self.session.run(None, {"x": np.ascontiguousarray(x, np.float32)})
        except Exception as exc:  # onnxruntime's own error types: a graph that does not fit its input
            raise NdrqlError(f"the graph {self.path} cannot run on this input: {str(exc).splitlines()[0][:200]}") from None
        return _sigmoid(region)[:, 0], _sigmoid(guide)[:, 0], (dist[0][:, 0] if dist else None)


def onnx_cache_path(weights: Path) -> Path:
    """Where the export of a checkpoint without a shipped graph is kept:
    ``$NDRQL_CACHE/onnx/<sha256 of the file, 16 hex>-any.onnx``, its record beside it (``.json``)."""
    from ndrql.dataset.cache import cache_dir  # lazy: start-up time (it loads the dataset layout); shipped graphs never need it

    return cache_dir() / "onnx" / f"{file_digest(weights)[:16]}-any.onnx"


def remove_stale_exports(onnx_path: Path) -> list[Path]:
    """Delete the exports an earlier ndrql kept for the same checkpoint (one graph per input side:
    ``<digest>.onnx`` for 201 px, ``<digest>-<side>.onnx``, and their ``.json`` records) beside the
    current ``<digest>-any.onnx``; returns what it removed. Files of other checkpoints stay."""
    digest = onnx_path.name.split("-")[0]
    removed = []
    for f in onnx_path.parent.glob(f"{digest}*"):
        rest = f.stem[len(digest):]
        if f.suffix in (".onnx", ".json") and (rest == "" or (rest[:1] == "-" and rest[1:].isdigit())):
            f.unlink(missing_ok=True)
            removed.append(f)
    return removed


def cached_graph(weights: Path) -> tuple[Path | None, bool]:
    """A cache hit for ``weights``, without torch: ``(graph, True)``; ``(None, True)`` when the record says the
    model has no graph (no guideline output); ``(None, False)`` when nothing usable is cached. A damaged
    graph (its SHA-256 differs from the record) is reported with a warning and counts as not cached."""
    onnx_path = onnx_cache_path(weights)
    try:
        meta = json.loads(onnx_path.with_suffix(".json").read_text())
    except (OSError, ValueError):
        return None, False  # no export yet, or a damaged record: export again
    if not isinstance(meta, dict) or meta.get("format") != EXPORT_FORMAT:
        return None, False
    if not meta.get("exported"):
        return None, True
    recorded = meta.get("onnx_sha256")
    if recorded and onnx_path.is_file() and file_digest(onnx_path) == recorded:
        return onnx_path, True
    if recorded:
        warnings.warn(f"the cached ONNX export {onnx_path} is damaged; exporting it again", stacklevel=3)
    return None, False


def find_graph(weights: Path) -> tuple[Path | None, bool]:
    """The graph for ``weights`` without exporting: ``(path, True)`` when one exists, ``(None, True)`` for a
    model known to have none, ``(None, False)`` when it has to be exported first (see the module docstring)."""
    if weights.suffix.lower() == ".onnx":
        return weights, True
    shipped = shipped_graph(weights)
    if shipped is not None:
        return shipped, True
    return cached_graph(weights)


def onnx_runner(weights: Path, threads: int = 0,
                export: Callable[[Path], Path | None] | None = None) -> OnnxRunner | None:
    """A runner for ``weights``; ``None`` for a model without a guideline output, or when its graph would
    have to be exported and there is no ``export`` (:func:`ndrql.model.export.cached_export`) or
    :func:`can_export` is False. A cached export that ONNX Runtime cannot load is exported again once
    (with a warning)."""
    graph, known = find_graph(weights)
    if graph is None and (known or export is None or not can_export()):
        return None
    fresh = graph is None
    if fresh:
        graph = export(weights)
        if graph is None:
            return None
    try:
        return OnnxRunner(graph, threads)
    except NdrqlError:
        raise
    except Exception as exc:  # noqa: BLE001 - onnxruntime raises its own exception types
        if fresh or export is None or graph != onnx_cache_path(weights) or not can_export():
            raise
        warnings.warn(f"the cached ONNX export {graph} does not load ({type(exc).__name__}); exporting it again",
                      stacklevel=3)
    graph = export(weights)
    assert graph is not None  # it was exported before
    return OnnxRunner(graph, threads)
