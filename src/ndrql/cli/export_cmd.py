"""``ndrql export-weights`` and ``ndrql export-onnx``: ship a trained model."""

from __future__ import annotations

import argparse
from pathlib import Path

from ndrql.limits import check_int
from ndrql.model.export import export_onnx
from ndrql.model.weights import resolve_weights


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("export-weights", help="slim fp16 inference checkpoint from a training checkpoint",
                       description="Write config, metrics and fp16 weights (no optimizer state) from a training checkpoint.")
    p.add_argument("checkpoint", help="training checkpoint (e.g. ~/.cache/ndrql/runs/ndr-default/best.pt)")
    p.add_argument("--out", required=True, help="output file (e.g. src/ndrql/data/ndr_default.pt)")
    p.add_argument("--fp32", action="store_true", help="keep fp32 weights")
    p.set_defaults(func=run_weights)

    q = sub.add_parser("export-onnx", help="export the NDR model to ONNX (runs on ONNX Runtime, no torch)",
                       description="Export a checkpoint to ONNX: one graph for every input side and batch size, the model "
                                   "config in its metadata, so `--weights FILE.onnx` plans without torch. "
                                   "Example: ndrql export-onnx --weights run/best.pt --out best.onnx")
    q.add_argument("--weights", help="checkpoint (default: the shipped model)")
    q.add_argument("--out", required=True, help="output .onnx file")
    q.add_argument("--size", type=int, default=None,
                   help="fix the input to SIZE x SIZE px (default: any side)")
    q.set_defaults(func=run_onnx)


def run_weights(args: argparse.Namespace) -> int:
    from ndrql.model.checkpoint import export_weights  # lazy: loads torch

    out = export_weights(args.checkpoint, args.out, half=not args.fp32)
    print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB)")
    return 0


def run_onnx(args: argparse.Namespace) -> int:
    if args.size is not None:
        check_int(args.size, "--size", 32, 4096)
    out = export_onnx(resolve_weights(args.weights), args.out, args.size)
    print(f"wrote {out}")
    return 0
