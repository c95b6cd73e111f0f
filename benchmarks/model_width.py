"""Training-step cost of the NDR model sizes, fp32 vs bf16, in one run (picks the CPU default).

For each preset (quarter, half = default, full STDC1) and precision: median wall seconds of one
optimisation step (forward, BCE + Dice on both outputs, backward, AdamW) on a real-looking batch of
16 at 201x201, channels_last, and the ratio to the reference (half width, fp32).

    python benchmarks/model_width.py [--threads 2] [--steps 5] [--batch 16] [--presets a,b] [--precisions fp32,bf16] [--override JSON]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time

import torch

from ndrql.model.registry import build_model, preset
from ndrql.training.losses import ndr_loss

PRESETS = ("ndr-stdc1-quarter", "ndr-stdc1-half", "ndr-stdc1")


def step_time(name: str, bf16: bool, batch: int, steps: int, overrides: dict | None = None) -> tuple[float, float]:
    """(median seconds per step, parameters in millions)."""
    torch.manual_seed(0)
    model = build_model(preset(name, **(overrides or {}))).to(memory_format=torch.channels_last).train()
    opt = torch.optim.AdamW(model.parameters(), lr=1e-3)
    g = torch.Generator().manual_seed(0)
    x = torch.zeros(batch, 3, 201, 201)
    x[:, 0] = (torch.rand(batch, 201, 201, generator=g) > 0.8).float()
    x[:, 1, 10, 10] = 1
    x[:, 2, 190, 190] = 1
    x = x.contiguous(memory_format=torch.channels_last)
    region = (torch.rand(batch, 1, 201, 201, generator=g) > 0.85).float()
    guide = (torch.rand(batch, 1, 201, 201, generator=g) > 0.98).float()
    times = []
    for i in range(steps + 1):
        t0 = time.perf_counter()
        with torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
            r, gl = model(x)
        loss = ndr_loss(r, gl, region, guide)
        opt.zero_grad()
        loss.backward()
        opt.step()
        if i:  # first step warms up oneDNN
            times.append(time.perf_counter() - t0)
    return statistics.median(times), sum(p.numel() for p in model.parameters()) / 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--steps", type=int, default=5)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--presets", default=",".join(PRESETS), help="comma-separated presets (ndrql.model.registry.PRESETS)")
    ap.add_argument("--precisions", default="fp32,bf16", help="fp32, bf16 or both")
    ap.add_argument("--override", default="{}", help='JSON config fields applied to every preset, e.g. \'{"unet_base": 8}\'')
    args = ap.parse_args()
    overrides = json.loads(args.override)
    presets = [p for p in args.presets.split(",") if p]
    precisions = [p == "bf16" for p in args.precisions.split(",") if p]
    torch.set_num_threads(args.threads)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, torch {torch.__version__}, "
          f"{args.threads} threads, batch {args.batch}, 201x201, overrides {overrides}")
    ref, _ = step_time("ndr-stdc1-half", False, args.batch, args.steps, overrides)
    print("| preset | params (M) | precision | s/step | samples/s | time vs half fp32 | epoch (11,392 samples) min |")
    print("|---|---:|---|---:|---:|---:|---:|")
    for name in presets:
        for bf16 in precisions:
            t, params = (ref, None) if (name == "ndr-stdc1-half" and not bf16) else step_time(name, bf16, args.batch, args.steps, overrides)
            if params is None:
                params = sum(p.numel() for p in build_model(preset(name, **overrides)).parameters()) / 1e6
            print(f"| {name} | {params:.2f} | {'bf16' if bf16 else 'fp32'} | {t:.2f} | {args.batch / t:.1f} | {t / ref:.2f} | "
                  f"{11392 / (args.batch / t) / 60:.1f} |", flush=True)


if __name__ == "__main__":
    main()
