"""ONNX export of a checkpoint: the form ONNX Runtime runs without torch (``ndrql export-onnx``,
the shipped graphs of :mod:`ndrql.model.shipped`).

The graph takes ``x`` (B, C, H, W) and returns the ``region`` and ``guideline`` logits (B, 1, H, W)
(and the raw ``distance`` output of a model with a distance head).
By default batch, height and width are all dynamic: one graph serves every input side (the pyramid
pooling and the padding take their size-generic form while traced, :func:`ndrql.model.layers.exporting`).
Weights that fp16 holds exactly (the shipped checkpoints are stored in fp16) are stored as fp16 and
cast back to fp32 when the graph loads, and BatchNorm stays its own op (ONNX Runtime folds it into
the convolution at load), so the graph computes with the checkpoint's own fp32 weights at half the
file size. The model config and the checkpoint's SHA-256 ride in the graph's metadata.

:func:`export_shipped` regenerates a shipped graph and its record (:mod:`ndrql.model.shipped`),
measuring it against torch at every side ``plan`` uses.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ndrql.dataset.encodings import encode_input, has_unknown
from ndrql.errors import NdrqlError, require_torch
from ndrql.io import atomic_path, file_digest, write_json
from ndrql.maps.grid import MODEL_SIDE
from ndrql.model.onnx_backend import CONFIG_KEY, EXPORT_FORMAT, FORMAT_KEY, WEIGHTS_KEY, OnnxRunner, onnx_cache_path, remove_stale_exports
from ndrql.model.shipped import CHECK_SIDES, TOLERANCE, graph_path, record_path, shipped_file

#: Side of the example input the dynamic graph is traced with (any side gives the same graph).
TRACE_SIDE = MODEL_SIDE
#: Smallest tensor (elements) stored as fp16; smaller ones are not worth a Cast node.
MIN_HALF_ELEMENTS = 16


def export_onnx(weights: str | Path, out: str | Path, size: int | None = None) -> Path:
    """Export the model in ``weights`` to ONNX at ``out`` (written by :mod:`ndrql.io`): any input side when
    ``size`` is None, else fixed ``size`` x ``size`` (batch dynamic either way). Needs torch and onnx."""
    require_torch("exporting a model to ONNX")
    try:
        import onnx
    except ImportError:
        raise NdrqlError("ONNX export needs the 'onnx' package: pip install 'ndrql[train]'") from None
    import torch  # lazy: torch is optional

    from ndrql.model.checkpoint import load_checkpoint, model_from_checkpoint  # lazy: torch is optional

    data = load_checkpoint(weights)
    config = dict(data["config"])
    model = model_from_checkpoint(data).eval()
    side = TRACE_SIDE if size is None else int(size)
    dummy = torch.zeros(1, int(config.get("in_channels", 3)), side, side)
    outputs = ["region", "guideline"] + (["distance"] if config.get("distance_head") else [])
    axes = {0: "batch"} if size is not None else {0: "batch", 2: "height", 3: "width"}
    out = Path(out)
    with atomic_path(out) as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore", torch.jit.TracerWarning)  # sizes are symbolic where it matters (tested)
        warnings.simplefilter("ignore", DeprecationWarning)  # the TorchScript exporter handles this model
        warnings.filterwarnings("ignore", "It is recommended that constant folding be turned off")  # for training mode; the model is in eval
        torch.onnx.export(model, (dummy,), str(tmp), input_names=["x"], output_names=outputs,
                          dynamic_axes={name: axes for name in ["x", *outputs]}, opset_version=17,
                          dynamo=False, training=torch.onnx.TrainingMode.PRESERVE)
        graph = onnx.load(str(tmp))
        store_half(graph)
        onnx.helper.set_model_props(graph, {CONFIG_KEY: json.dumps(config, sort_keys=True),
                                            WEIGHTS_KEY: file_digest(weights), FORMAT_KEY: str(EXPORT_FORMAT)})
        onnx.save(graph, str(tmp))
    return out


def cached_export(weights: Path) -> Path | None:
    """Export ``weights`` into the ONNX cache (:func:`ndrql.model.onnx_backend.onnx_cache_path`; needs torch
    and onnx) and record it; ``None`` for a model without
    a guideline output (the ONNX backend needs both outputs). A bad checkpoint raises CheckpointError."""
    from ndrql.model.checkpoint import load_checkpoint  # lazy: torch is optional

    onnx_path = onnx_cache_path(weights)
    config = dict(load_checkpoint(weights)["config"])
    exported = bool(config.get("guideline_decoder", True))
    record: dict[str, Any] = {"format": EXPORT_FORMAT, "exported": exported, "weights": str(weights)}
    if exported:
        export_onnx(weights, onnx_path)
        record["onnx_sha256"] = file_digest(onnx_path)
    write_json(onnx_path.with_suffix(".json"), record)
    remove_stale_exports(onnx_path)
    return onnx_path if exported else None


def store_half(model) -> int:
    """Store every fp32 initializer of the ONNX ``model`` that fp16 holds exactly as fp16 plus a Cast back
    to fp32 (in place); returns how many were converted. Values are unchanged bit for bit."""
    from onnx import TensorProto, helper, numpy_helper

    graph = model.graph
    keep, half, casts = [], [], []
    for init in graph.initializer:
        if init.data_type == TensorProto.FLOAT:
            a = numpy_helper.to_array(init)
            h = a.astype(np.float16)
            if a.size >= MIN_HALF_ELEMENTS and np.array_equal(h.astype(np.float32), a):
                half.append(numpy_helper.from_array(h, f"{init.name}__fp16"))
                casts.append(helper.make_node("Cast", [f"{init.name}__fp16"], [init.name], to=TensorProto.FLOAT,
                                              name=f"{init.name}__cast"))
                continue
        keep.append(init)
    del graph.initializer[:]
    graph.initializer.extend(keep + half)
    nodes = list(graph.node)
    del graph.node[:]
    graph.node.extend(casts + nodes)
    return len(half)


def sample_inputs(side: int, channels: int, encoding: str, count: int, seed: int) -> np.ndarray:
    """``count`` encoded inputs of ``side`` px: random obstacles (20 %), a free start and goal, and for an encoding with
    the unknown channel 30 % of the pixels unknown, so the channel is measured too (deterministic per seed)."""
    rng = np.random.default_rng(seed)
    batch = []
    for _ in range(count):
        obstacles = rng.random((side, side)) < 0.2
        free = np.argwhere(~obstacles)
        s, g = free[rng.choice(len(free), 2, replace=False)]
        unknown = rng.random((side, side)) < 0.3 if has_unknown(encoding) else None
        batch.append(encode_input(obstacles, tuple(map(int, s)), tuple(map(int, g)), encoding, unknown))
    x = np.stack(batch).astype(np.float32)
    if x.shape[1] != channels:
        raise ValueError(f"encoding {encoding!r} gives {x.shape[1]} channels, the model takes {channels}")
    return x


def max_differences(weights: Path, graph: Path, sides: tuple[int, ...] = CHECK_SIDES, count: int = 2,
                    seed: int = 0) -> dict[int, dict[str, float]]:
    """Largest |probability difference| between torch and ONNX Runtime per input side, for region and
    guideline (and the relative difference of the distance output), on :func:`sample_inputs` (needs torch)."""
    import torch  # lazy: torch is optional

    from ndrql.model.checkpoint import load_checkpoint, model_from_checkpoint  # lazy: torch is optional

    model = model_from_checkpoint(load_checkpoint(weights)).eval()
    runner = OnnxRunner(graph, threads=1)
    channels = int(runner.config.get("in_channels", 3))
    out: dict[int, dict[str, float]] = {}
    for side in sides:
        x = sample_inputs(side, channels, runner.config.get("encoding", "point"), count, seed + side)
        with torch.inference_mode():
            region, guide, *dist = model(torch.from_numpy(x))
        tr, tg = torch.sigmoid(region)[:, 0].numpy(), torch.sigmoid(guide)[:, 0].numpy()
        orr, og, od = runner(x)
        out[side] = {"region": float(np.abs(tr - orr).max()), "guideline": float(np.abs(tg - og).max())}
        if dist:  # raw output in DISTANCE_UNIT cells: compared relative to its size
            td = dist[0][:, 0].numpy()
            out[side]["distance"] = float((np.abs(td - od) / (1.0 + np.abs(td))).max())
    return out


def export_shipped(name: str, sides: tuple[int, ...] = CHECK_SIDES) -> dict[str, Any]:
    """Export the shipped checkpoint ``name`` (``paper``, ``general`` or a companion's file stem in the data
    folder, :func:`~ndrql.model.shipped.shipped_file`) to its graph, measure it against torch at ``sides`` and write
    the record; returns the record (needs torch and onnx). Raises ValueError when a side differs by more
    than :data:`TOLERANCE`, leaving the old record in place."""
    import onnxruntime
    import torch  # lazy: torch is optional

    weights, graph = shipped_file(name), graph_path(name)
    export_onnx(weights, graph)
    diffs = max_differences(weights, graph, sides)
    worst = max(max(d.values()) for d in diffs.values())
    if worst > TOLERANCE:
        raise ValueError(f"the ONNX graph of {name!r} differs from torch by {worst:.2e} (> {TOLERANCE:g}): {diffs}")
    record = {
        "weights": weights.name, "weights_sha256": file_digest(weights),
        "onnx": graph.name, "onnx_sha256": file_digest(graph), "onnx_bytes": graph.stat().st_size,
        "exported_with": {"torch": torch.__version__.split("+")[0], "onnxruntime": onnxruntime.__version__},
        "max_abs_difference": {str(side): d for side, d in diffs.items()},
    }
    write_json(record_path(name), record)
    return record
