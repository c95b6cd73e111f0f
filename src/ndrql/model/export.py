"""ONNX export of a checkpoint (ONNX Runtime is an optional, faster CPU inference path)."""

from __future__ import annotations

import warnings
from pathlib import Path

from ndrql.errors import NdrqlError
from ndrql.io import atomic_path
from ndrql.maps.grid import MODEL_SIDE


def export_onnx(weights: str | Path, out: str | Path, size: int = MODEL_SIDE) -> Path:
    """Export the model in ``weights`` to ONNX at ``size`` x ``size``, dynamic batch (written by :mod:`ndrql.io`)."""
    import torch

    from ndrql.model.checkpoint import load_checkpoint, model_from_checkpoint  # lazy: loads torch

    data = load_checkpoint(weights)
    model = model_from_checkpoint(data).eval()
    cin = int(dict(data["config"]).get("in_channels", 3))
    out = Path(out)
    dummy = torch.zeros(1, cin, size, size)
    try:
        with atomic_path(out) as tmp, warnings.catch_warnings():  # shapes are fixed on purpose: the export is for size x size inputs
            warnings.simplefilter("ignore", torch.jit.TracerWarning)
            warnings.simplefilter("ignore", DeprecationWarning)  # the TorchScript exporter handles this model; dynamo export does not need it
            torch.onnx.export(model, (dummy,), str(tmp), input_names=["x"], output_names=["region", "guideline"],
                              dynamic_axes={"x": {0: "batch"}, "region": {0: "batch"}, "guideline": {0: "batch"}},
                              opset_version=17, dynamo=False)
    except ImportError as exc:
        raise NdrqlError(f"ONNX export needs the 'onnx' package: pip install 'ndrql[onnx]' ({exc})") from None
    return out
