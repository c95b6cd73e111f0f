"""``ndrql export-weights`` and ``ndrql export-onnx``: ship a trained model."""

from __future__ import annotations

import argparse
from pathlib import Path

from ndrql.errors import NdrqlError
from ndrql.limits import check_int
from ndrql.model.export import export_onnx
from ndrql.model.weights import resolve_weights


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("export-weights", help="slim fp16 inference checkpoint from a training checkpoint",
                       description="Write config, metrics and fp16 weights (no optimizer state) from a training checkpoint.")
    p.add_argument("checkpoint", help="training checkpoint (e.g. ~/.cache/ndrql/runs/ndr-default/best.pt)")
    p.add_argument("--out", required=True, help="output file (e.g. src/ndrql/data/ndr_default.pt)")
    p.add_argument("--fp32", action="store_true", help="keep fp32 weights")
    p.add_argument("--view", default=None, metavar="VIEW",
                   help="serve a grid-mode model under this view: native, cap:PX, coarse:CELLS or walls:CELLS (default: the checkpoint's)")
    p.add_argument("--merged-weights", default=None, metavar="STEM",
                   help="companion weights serving the grids a coarse or walls view merges: a file stem beside the output, "
                        "same suffix (e.g. ndr_general_large); \"\" clears it (default: the checkpoint's)")
    p.set_defaults(func=run_weights)

    a = sub.add_parser("average-weights", help="average the weights of models of one architecture (a model soup)",
                       description="Write the (weighted) average of the weights of two or more checkpoints of the same "
                                   "architecture as a slim fp16 checkpoint; which files went in, with their digests, is "
                                   "recorded in it. Example: ndrql average-weights a.pt b.pt --out soup.pt")
    a.add_argument("weights", nargs="+", help="checkpoints to average (at least two)")
    a.add_argument("--shares", default=None, metavar="W1,W2,...", help="relative share of each file (default: equal)")
    a.add_argument("--out", required=True, help="output file")
    a.set_defaults(func=run_average)

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

    out = export_weights(args.checkpoint, args.out, half=not args.fp32, view=args.view,
                         merged_weights=args.merged_weights)
    print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB)")
    return 0


def run_average(args: argparse.Namespace) -> int:
    from ndrql.model.checkpoint import average_weights  # lazy: loads torch

    if len(args.weights) < 2:
        raise NdrqlError("average-weights: give at least two weights files")
    if any(Path(w).resolve() == Path(args.out).resolve() for w in args.weights):
        raise NdrqlError(f"average-weights: --out {args.out} is one of the inputs; choose another file")
    shares = None
    if args.shares is not None:
        try:
            shares = [float(v) for v in args.shares.split(",")]
        except ValueError:
            raise NdrqlError(f"--shares must be numbers separated by commas, got {args.shares!r}") from None
    out = average_weights(args.weights, args.out, shares)
    print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB), the average of {len(args.weights)} models")
    return 0


def run_onnx(args: argparse.Namespace) -> int:
    if args.size is not None:
        check_int(args.size, "--size", 32, 4096)
    out = export_onnx(resolve_weights(args.weights), args.out, args.size)
    print(f"wrote {out}")
    return 0
