"""ONNX Runtime backend of the Predictor: one session runs every input side, no torch needed.

Where the graph comes from (:func:`find_graph`), in this order:

- the shipped weights (``paper``, ``general``) ship their graph beside the .pt file
  (:mod:`ndrql.model.shipped`), matched by the .pt's SHA-256: nothing to export;
- an ``.onnx`` file written by ``ndrql export-onnx`` is used as it is (its metadata holds the model
  config);
- any other checkpoint is exported once, on first use, into ``$NDRQL_CACHE/onnx`` (needs torch and
  onnx: :func:`ndrql.model.export.cached_export`, handed to :func:`onnx_runner`); a cache hit needs
  neither.

ONNX Runtime optimises a graph each time it opens it (about 0.15 s of the shipped ``general`` graph's
0.2 s session). :func:`onnx_runner` keeps the graph it optimised in ``$NDRQL_CACHE/onnx/ort``
(:func:`optimized_path`) and opens that with optimisation off on later runs: the same operations,
the same outputs bit for bit. An optimised graph is specific to the machine and to ONNX Runtime's
version, so its name holds both, with the source graph's SHA-256. A cached file that does not load is
made again; a cache folder that cannot be written costs the optimisation on every run, nothing more.

Only ``onnxruntime`` is imported here; this module never imports the exporter (or torch).
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import platform
import warnings
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ndrql.errors import NdrqlError
from ndrql.io import atomic_path, cache_dir, file_digest, note_input
from ndrql.model.shipped import graph_path as shipped_graph_path
from ndrql.model.shipped import record_path, shipped_graph
from ndrql.model.weights import SHIPPED_WEIGHTS

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


def _options(threads: int) -> Any:
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = max(0, threads)
    opts.inter_op_num_threads = 1
    return opts


def _session(path: Path, opts: Any) -> Any:
    import onnxruntime as ort

    note_input(path, "the ONNX graph")
    return ort.InferenceSession(str(path), sess_options=opts, providers=["CPUExecutionProvider"])


def machine_key() -> str:
    """What an optimised graph is specific to, short: the CPU architecture and a digest of the CPU's
    vendor, model and feature flags (``/proc/cpuinfo`` where there is one, else what :mod:`platform` says)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            block = fh.read(1 << 16).split("\n\n", 1)[0]  # the first processor's lines
        lines = sorted(line for line in block.splitlines()
                       if line.split(":", 1)[0].strip() in ("vendor_id", "model name", "flags", "Features", "CPU implementer",
                                                             "CPU part", "isa", "cpu"))
    except OSError:
        lines = []
    text = "\n".join(lines) or f"{platform.system()} {platform.processor()}"
    return f"{platform.machine() or 'unknown'}-{hashlib.sha256(text.encode()).hexdigest()[:12]}"


def optimized_path(digest: str) -> Path:
    """Where the optimised form of the graph whose SHA-256 is ``digest`` is kept for this machine and this
    ONNX Runtime: ``$NDRQL_CACHE/onnx/ort/<digest, 16 hex>-ort<version>-<machine_key()>.onnx``."""
    import onnxruntime as ort

    return cache_dir() / "onnx" / "ort" / f"{digest[:16]}-ort{ort.__version__}-{machine_key()}.onnx"


def open_session(onnx_path: Path, threads: int = 0, digest: str | None = None, cache: bool = False) -> Any:
    """An ONNX Runtime CPU session of ``onnx_path`` on ``threads`` intra-op threads (0 = ONNX Runtime's default).

    ``cache``: open the optimised graph kept in :func:`optimized_path` (``digest``: the SHA-256 of
    ``onnx_path``, computed when not given) with optimisation off, or, when there is none or it does not
    load, optimise ``onnx_path`` as usual and keep the result there (atomically). When the cache folder
    cannot be written the session is the usual one."""
    if not cache:
        return _session(onnx_path, _options(threads))
    import onnxruntime as ort

    try:
        cached = optimized_path(digest or file_digest(onnx_path))
        hit = cached.is_file()
    except OSError:  # an unreadable graph (the session below says so) or a cache folder that cannot be searched
        return _session(onnx_path, _options(threads))
    if hit:
        opts = _options(threads)
        opts.graph_optimization_level = ort.GraphOptimizationLevel.ORT_DISABLE_ALL
        try:
            return _session(cached, opts)
        except Exception:  # noqa: BLE001 - onnxruntime's own error types: a damaged file, made again below
            pass
    opts = _options(threads)
    opts.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL  # the default, spelled out
    opts.log_severity_level = 3  # no warning that the saved graph is specific to this machine: its name says so
    try:
        with atomic_path(cached) as tmp:
            opts.optimized_model_filepath = str(tmp)
            session = _session(onnx_path, opts)
            if not tmp.is_file() or tmp.stat().st_size == 0:
                raise OSError("ONNX Runtime did not write the optimised graph")
    except Exception:  # noqa: BLE001 - the folder cannot be written (OutputError), or ONNX Runtime failed to
        return _session(onnx_path, _options(threads))  # save: the usual session (which raises for a bad graph)
    return session


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

    def __init__(self, onnx_path: Path, threads: int = 0, digest: str | None = None, cache: bool = False):
        self.path = Path(onnx_path)
        self.session = open_session(self.path, threads, digest, cache)
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


def _checked_digest(weights: Path, graph: Path) -> str | None:
    """The SHA-256 of ``graph`` that :func:`find_graph` has just checked it against (the record of a shipped
    graph or of a cached export), so that it is not read twice; ``None`` for a graph given as it is."""
    if weights.suffix.lower() == ".onnx":
        return None
    records = {shipped_graph_path(name): record_path(name) for name in SHIPPED_WEIGHTS}
    record = records.get(graph, graph.with_suffix(".json"))
    try:
        digest = json.loads(record.read_text()).get("onnx_sha256")
    except (OSError, ValueError, AttributeError):
        return None
    return digest if isinstance(digest, str) and len(digest) == 64 else None


def onnx_runner(weights: Path, threads: int = 0,
                export: Callable[[Path], Path | None] | None = None) -> OnnxRunner | None:
    """A runner for ``weights``; ``None`` for a model without a guideline output, or when its graph would
    have to be exported and there is no ``export`` (:func:`ndrql.model.export.cached_export`) or
    :func:`can_export` is False. A cached export that ONNX Runtime cannot load is exported again once
    (with a warning). The session comes from ONNX Runtime's optimised graph kept in the cache
    (:func:`open_session`)."""
    graph, known = find_graph(weights)
    if graph is None and (known or export is None or not can_export()):
        return None
    fresh = graph is None
    if fresh:
        graph = export(weights)
        if graph is None:
            return None
    try:
        return OnnxRunner(graph, threads, digest=None if fresh else _checked_digest(weights, graph), cache=True)
    except NdrqlError:
        raise
    except Exception as exc:  # noqa: BLE001 - onnxruntime raises its own exception types
        if fresh or export is None or graph != onnx_cache_path(weights) or not can_export():
            raise
        warnings.warn(f"the cached ONNX export {graph} does not load ({type(exc).__name__}); exporting it again",
                      stacklevel=3)
    graph = export(weights)
    assert graph is not None  # it was exported before
    return OnnxRunner(graph, threads, cache=True)
