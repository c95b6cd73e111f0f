"""NDR model inference speed on the CPU: every option against plain eager fp32, in the same run.

Batch-1 latency (median of N calls) and batch throughput at 201x201 for: eager fp32 (reference),
inference_mode, + channels_last, + bf16 autocast, torch.compile, and ONNX Runtime (if installed).
Also checks each variant's outputs against the reference (max abs difference of probabilities). The
last row is what ``ndrql plan`` runs by default: ONNX Runtime on the input in 4 orientations (one
batch), turned back and averaged (:mod:`ndrql.model.symmetry`); its difference from the reference is
that of another estimate, not an error. Models with a goal-distance head time all three outputs and
compare region and guideline.

    python benchmarks/inference_speed.py [--weights FILE] [--threads 2] [--repeat 30] [--batch 16]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import tempfile
import time

import numpy as np
import torch

from ndrql.model.predict import default_weights_path
from ndrql.model.checkpoint import load_checkpoint, model_from_checkpoint
from ndrql.model.symmetry import DEFAULT_COUNT, averaged


def timed(fn, x, repeat: int) -> float:
    """Median seconds per call after two warm-up calls."""
    fn(x)
    fn(x)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn(x)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--weights", default=None)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=30)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--no-compile", action="store_true", help="skip torch.compile (slow to warm up)")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    weights = args.weights or default_weights_path()
    ck = load_checkpoint(weights)
    model = model_from_checkpoint(ck).eval()
    rng = np.random.default_rng(0)
    x1 = torch.from_numpy((rng.random((1, 3, 201, 201)) > 0.8).astype(np.float32))
    xb = torch.from_numpy((rng.random((args.batch, 3, 201, 201)) > 0.8).astype(np.float32))

    def eager(x):
        with torch.no_grad():
            r, g, *_ = model(x)
        return torch.sigmoid(r), torch.sigmoid(g)

    def inference(x):
        with torch.inference_mode():
            r, g, *_ = model(x)
        return torch.sigmoid(r), torch.sigmoid(g)

    model_cl = model_from_checkpoint(ck).eval().to(memory_format=torch.channels_last)

    def channels_last(x):
        with torch.inference_mode():
            r, g, *_ = model_cl(x.contiguous(memory_format=torch.channels_last))
        return torch.sigmoid(r), torch.sigmoid(g)

    def bf16(x):
        with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16):
            r, g, *_ = model_cl(x.contiguous(memory_format=torch.channels_last))
        return torch.sigmoid(r.float()), torch.sigmoid(g.float())

    variants = {"eager fp32 (reference)": eager, "inference_mode": inference, "+ channels_last": channels_last,
                "+ bf16 autocast": bf16}
    if not args.no_compile:
        try:
            compiled = torch.compile(model_from_checkpoint(ck).eval())

            def comp(x):
                with torch.inference_mode():
                    r, g, *_ = compiled(x)
                return torch.sigmoid(r), torch.sigmoid(g)

            comp(x1)
            variants["torch.compile"] = comp
        except Exception as exc:  # no compiler toolchain, etc.
            print(f"torch.compile unavailable: {type(exc).__name__}: {exc}")
    try:
        import onnxruntime as ort

        from ndrql.model.export import export_onnx

        path = os.path.join(tempfile.mkdtemp(), "ndr.onnx")
        export_onnx(weights, path)
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = args.threads
        sess = ort.InferenceSession(path, opts, providers=["CPUExecutionProvider"])

        def onnx(x):
            r, g, *_ = sess.run(None, {"x": x.numpy()})
            return torch.sigmoid(torch.from_numpy(r)), torch.sigmoid(torch.from_numpy(g))

        def onnx_turned(x):
            def runner(a):
                r, g, *_ = sess.run(None, {"x": np.ascontiguousarray(a)})
                return 1 / (1 + np.exp(-r)), 1 / (1 + np.exp(-g))

            r, g = averaged(runner, x.numpy(), DEFAULT_COUNT)
            return torch.from_numpy(r), torch.from_numpy(g)

        variants["ONNX Runtime"] = onnx
        variants[f"ONNX Runtime, {DEFAULT_COUNT} orientations averaged (plan's default; a different estimate)"] = onnx_turned
    except ImportError:
        print("onnxruntime not installed: pip install onnxruntime")

    ref1, refb = eager(x1), eager(xb)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, torch {torch.__version__}, "
          f"{args.threads} threads, weights {os.path.basename(str(weights))}")
    print(f"| variant | batch-1 latency (ms) | speed-up | batch-{args.batch} throughput (img/s) | speed-up | max abs diff |")
    print("|---|---:|---:|---:|---:|---:|")
    base_lat = base_thr = None
    for name, fn in variants.items():
        lat = timed(fn, x1, args.repeat)
        thr = args.batch / timed(fn, xb, max(3, args.repeat // 6))
        base_lat = base_lat or lat
        base_thr = base_thr or thr
        out = fn(x1)
        diff = max(float((out[0] - ref1[0]).abs().max()), float((out[1] - ref1[1]).abs().max()))
        print(f"| {name} | {1000 * lat:.1f} | {base_lat / lat:.2f}x | {thr:.1f} | {thr / base_thr:.2f}x | {diff:.1e} |", flush=True)
    del refb


if __name__ == "__main__":
    main()
