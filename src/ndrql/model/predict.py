"""Prediction API: region and guideline probabilities for any map, with the shipped model by default.

Maps that are not 201x201 are brought to the model's scale first and the probabilities mapped back
to the map's own size (:func:`ndrql.dataset.render.to_model_input`, :func:`~ndrql.dataset.render.from_model_output`).
"""

from __future__ import annotations

import contextlib
import functools
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from ndrql.dataset.cache import cache_dir
from ndrql.dataset.encodings import encode_input
from ndrql.dataset.render import from_model_output, to_model_input
from ndrql.errors import CheckpointError, NdrqlError, PointError
from ndrql.io import file_digest, write_json
from ndrql.maps.grid import MODEL_SIDE
from ndrql.model.export import export_onnx
from ndrql.model.weights import resolve_weights

Point = tuple[int, int]


@dataclass(frozen=True)
class Prediction:
    """Model output at the map's resolution, probabilities in [0, 1]."""

    region: np.ndarray
    guideline: np.ndarray | None


def default_weights_path() -> Path:
    """``$NDRQL_WEIGHTS`` if set (a name or a path), else the shipped default weights
    (:data:`ndrql.model.weights.DEFAULT_WEIGHTS`)."""
    return resolve_weights(None)


#: Inference backends: ``auto`` is ONNX Runtime when it (and ``onnx``, for the one-time export) is
#: installed and the model has both outputs, else torch. Measured in docs/performance.md ("NDR model").
BACKENDS = ("auto", "onnx", "torch")


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return (1.0 / (1.0 + np.exp(-np.asarray(x, np.float64)))).astype(np.float32)


def onnx_available() -> bool:
    """True when ONNX Runtime and the ``onnx`` exporter package can be imported."""
    import importlib.util

    return all(importlib.util.find_spec(m) is not None for m in ("onnxruntime", "onnx"))


@contextlib.contextmanager
def torch_threads(n: int) -> Iterator[None]:
    """Run torch ops on ``n`` threads inside the block (0 = leave as is), restoring the count after."""
    import torch

    before = torch.get_num_threads()
    if n and n != before:
        torch.set_num_threads(n)
    try:
        yield
    finally:
        if n and n != before:
            torch.set_num_threads(before)


class _TorchRunner:
    """Eager torch forward: inference_mode, channels_last, fp32, on ``threads`` threads (restored after)."""

    name = "torch"

    def __init__(self, model, threads: int):
        import torch

        self.model = model.eval().to(memory_format=torch.channels_last)
        self.threads = threads

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        import torch

        with torch_threads(self.threads), torch.inference_mode():
            t = torch.from_numpy(np.ascontiguousarray(x, np.float32)).contiguous(memory_format=torch.channels_last)
            region, guide = self.model(t)
        r = torch.sigmoid(region)[:, 0].numpy()
        g = torch.sigmoid(guide)[:, 0].numpy() if guide is not None else None
        return r, g


class _OnnxRunner:
    """ONNX Runtime sessions of the exported model, one per input side (dynamic batch).

    The network's pyramid pooling and padding are traced at a fixed input size, so every side gets its
    own export (made once on first use, cached by weights digest and side; see :func:`_onnx_model`).
    """

    name = "onnx"

    def __init__(self, weights: Path, threads: int, first: tuple[int, Path]):
        self.weights, self.threads = weights, threads
        self.sessions: dict[int, Any] = {}
        self.sessions[first[0]] = self._session(first[1])

    def _session(self, onnx_path: Path):
        import onnxruntime as ort

        opts = ort.SessionOptions()
        opts.intra_op_num_threads = max(0, self.threads)
        opts.inter_op_num_threads = 1
        return ort.InferenceSession(str(onnx_path), sess_options=opts, providers=["CPUExecutionProvider"])

    def session(self, side: int):
        if side not in self.sessions:
            found = _onnx_model(self.weights, side=side)
            assert found is not None  # the first side exported, so this model has both outputs
            try:
                self.sessions[side] = self._session(found[0])
            except Exception:  # noqa: BLE001 - a damaged cached export: export it again once
                self.sessions[side] = self._session(_onnx_model(self.weights, side=side, rebuild=True)[0])  # type: ignore[index]
        return self.sessions[side]

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        if x.shape[-1] != x.shape[-2]:
            raise ValueError(f"the model's input must be square, got {x.shape[-2]}x{x.shape[-1]}")
        region, guide = self.session(int(x.shape[-1])).run(None, {"x": np.ascontiguousarray(x, np.float32)})
        return _sigmoid(region)[:, 0], _sigmoid(guide)[:, 0]


def onnx_cache_path(weights: Path, side: int = MODEL_SIDE) -> Path:
    """Where the ONNX export of ``weights`` for ``side`` x ``side`` inputs is kept:
    ``$NDRQL_CACHE/onnx/<sha256 of the file>.onnx`` (201 px) or ``<sha256>-<side>.onnx``."""
    suffix = "" if side == MODEL_SIDE else f"-{side}"
    return cache_dir() / "onnx" / f"{file_digest(weights)[:16]}{suffix}.onnx"


def _onnx_model(weights: Path, rebuild: bool = False, side: int = MODEL_SIDE) -> tuple[Path, dict] | None:
    """The cached ONNX export of ``weights`` for ``side`` px inputs and its model config, exporting it on first use.

    A cache hit needs neither torch nor the checkpoint (same bytes, same model); the export is checked
    against the SHA-256 recorded beside it, and a damaged or truncated one is exported again once,
    with a warning (as is any export when ``rebuild``). A miss validates the checkpoint (clear
    CheckpointError) and exports it. ``None`` for models without a guideline output.
    """
    import json
    import warnings

    onnx_path = onnx_cache_path(weights, side)
    meta_path = onnx_path.with_suffix(".json")
    try:
        meta = json.loads(meta_path.read_text())
    except (OSError, ValueError):
        meta = None  # no export yet, or a damaged record: export again
    if isinstance(meta, dict) and isinstance(meta.get("config"), dict) and not rebuild:
        if not meta.get("exported"):
            return None
        recorded = meta.get("onnx_sha256")
        if recorded and onnx_path.is_file() and file_digest(onnx_path) == recorded:
            return onnx_path, meta["config"]
        if recorded:
            warnings.warn(f"the cached ONNX export {onnx_path} is damaged; exporting it again", stacklevel=3)
    from ndrql.model.checkpoint import load_checkpoint  # lazy: loads torch

    config = dict(load_checkpoint(weights)["config"])
    exported = config.get("guideline_decoder", True)
    record = {"config": config, "exported": exported, "weights": str(weights), "side": side}
    if exported:
        export_onnx(weights, onnx_path, size=side)
        record["onnx_sha256"] = file_digest(onnx_path)
    write_json(meta_path, record)
    return (onnx_path, config) if exported else None


def _onnx_runner(weights: Path, threads: int) -> tuple[Any, dict] | None:
    """An ONNX Runtime runner for ``weights`` and its model config; a cached export that ONNX Runtime cannot
    load is exported again once (with a warning). ``None`` for models without a guideline output."""
    import warnings

    found = _onnx_model(weights)
    if found is None:
        return None
    try:
        return _OnnxRunner(weights, threads, (MODEL_SIDE, found[0])), found[1]
    except Exception as exc:  # noqa: BLE001 - onnxruntime raises its own exception types
        warnings.warn(f"the cached ONNX export {found[0]} does not load ({type(exc).__name__}); exporting it again",
                      stacklevel=3)
    found = _onnx_model(weights, rebuild=True)
    assert found is not None
    return _OnnxRunner(weights, threads, (MODEL_SIDE, found[0])), found[1]


class Predictor:
    """A loaded NDR model: ``predict(obstacles, start, goal) -> Prediction`` at the map's size.

    The forward pass runs on torch or on ONNX Runtime (``backend``); both give the same probabilities
    to about 1e-4 (tested). ``backend_name`` says which one runs.
    """

    def __init__(self, runner, encoding: str = "point", input_mode: str = "map"):
        self._runner = runner
        self.encoding = encoding
        self.input_mode = input_mode
        """What the model was trained to see: ``map`` (the map resized) or ``grid`` (the planning grid at 4 px per cell)."""

    @property
    def backend_name(self) -> str:
        return self._runner.name

    @property
    def model(self):
        """The torch module (torch backend only)."""
        if not isinstance(self._runner, _TorchRunner):
            raise AttributeError("this Predictor runs on ONNX Runtime; load it with backend='torch' for the torch module")
        return self._runner.model

    @classmethod
    def from_model(cls, model, encoding: str = "point", threads: int = 0) -> "Predictor":
        """Wrap an in-memory torch model (eager backend)."""
        return cls(_TorchRunner(model, threads), encoding)

    @classmethod
    def load(cls, path: str | Path | None = None, threads: int = 0, backend: str = "auto") -> "Predictor":
        """Load weights from ``path`` (default: :func:`default_weights_path`) on ``backend`` (:data:`BACKENDS`)."""
        if backend not in BACKENDS:
            raise NdrqlError(f"unknown inference backend {backend!r}; valid: {', '.join(BACKENDS)}")
        path = resolve_weights(path)
        if not path.is_file():
            raise CheckpointError(
                f"missing model weights: {path} (reinstall ndrql, set NDRQL_WEIGHTS, or pass --weights / --prior-from)"
            )
        if backend == "onnx" and not onnx_available():
            raise NdrqlError("backend 'onnx' needs onnxruntime and onnx: pip install onnxruntime onnx")
        if backend != "torch" and onnx_available():
            try:
                found = _onnx_runner(path, threads)
                if found is not None:
                    return cls(found[0], encoding=found[1].get("encoding", "point"),
                               input_mode=found[1].get("input_mode", "map"))
            except CheckpointError:
                raise
            except Exception as exc:  # an unwritable cache, a failed export or session: torch still works
                if backend == "onnx":
                    raise NdrqlError(f"ONNX Runtime backend failed for {path}: {type(exc).__name__}: {exc}") from None
                import warnings

                warnings.warn(f"ONNX Runtime backend unavailable ({type(exc).__name__}: {exc}); using torch", stacklevel=2)
            else:
                if backend == "onnx":
                    raise NdrqlError(f"{path} holds a model without a guideline output; the ONNX backend needs both outputs")
        from ndrql.model.checkpoint import load_checkpoint, model_from_checkpoint  # lazy: loads torch

        data = load_checkpoint(path)
        config = dict(data["config"])
        out = cls.from_model(model_from_checkpoint(data), config.get("encoding", "point"), threads)
        out.input_mode = config.get("input_mode", "map")
        return out

    def predict_batch(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Probabilities for an encoded batch (B, C, H, W) -> (B, H, W) arrays."""
        return self._runner(x)

    def predict(self, obstacles: np.ndarray, start: Point, goal: Point) -> Prediction:
        """Region and guideline probabilities for one map, at the map's own resolution."""
        obstacles = np.asarray(obstacles, bool)
        for name, p in (("start", start), ("goal", goal)):
            if not (0 <= p[0] < obstacles.shape[0] and 0 <= p[1] < obstacles.shape[1]):
                raise PointError(f"{name} {tuple(p)} is outside the {obstacles.shape[0]}x{obstacles.shape[1]} map")
        grid, s, g, scale = to_model_input(obstacles, start, goal)
        r, gl = self.predict_batch(encode_input(grid, s, g, self.encoding)[None])
        region = from_model_output(r[0], obstacles.shape, scale)
        guide = from_model_output(gl[0], obstacles.shape, scale) if gl is not None else None
        return Prediction(region=region, guideline=guide)


def load_predictor(weights: str | os.PathLike | None = None, threads: int = 1, backend: str = "auto") -> Predictor:
    """The NDR model for ``weights`` (default: ``$NDRQL_WEIGHTS`` or the shipped file), loaded once per process.

    Loaded models are cached by path, size, modification time, threads and backend, so a second call
    is free and a replaced weights file is picked up. A missing or unreadable file raises
    :class:`~ndrql.errors.CheckpointError` with what to do. ``backend``: ``auto`` (ONNX Runtime when
    installed; torch is then not imported once the export is cached), ``onnx`` or ``torch``.
    """
    path = resolve_weights(weights)
    try:
        st = path.stat()
        key = (str(path.resolve()), st.st_size, st.st_mtime_ns)
    except OSError:
        key = (str(path), -1, -1)  # Predictor.load gives the clear "missing model weights" error
    return _cached_predictor(key, threads, backend)


@functools.lru_cache(maxsize=4)
def _cached_predictor(key: tuple[str, int, int], threads: int, backend: str) -> Predictor:
    return Predictor.load(key[0], threads=threads, backend=backend)


def predict(obstacles: np.ndarray, start: Point, goal: Point, weights: str | Path | None = None,
            backend: str = "auto") -> Prediction:
    """One-shot prediction with the shipped (or given) weights."""
    return Predictor.load(weights, backend=backend).predict(obstacles, start, goal)
