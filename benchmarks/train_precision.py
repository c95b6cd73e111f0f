"""Training step under bf16 autocast against fp32 on this CPU: does emulated bf16 cost more than it saves?

``ndrql train`` autocasts to bf16 on the CPU only when the CPU computes bf16 natively
(:func:`ndrql.training.distributed.cpu_has_bf16`: AVX512-BF16 or AMX); this benchmark measures why.
One optimisation step (forward, the loss with the distance head's ranking, backward, AdamW) of the
shipped ``general`` model (grid mode, distance head) on the same pre-built batch of planning grids,
alternating fp32 and bf16 in rounds, CPU time of the calling thread; it prints the median per
precision and the ratio bf16 / fp32 measured in the same run.

    .venv/bin/python benchmarks/train_precision.py --side 512 --rounds 3 --threads 1

Synthetic grids (random blocks, a corridor from start to goal) stand in for training samples: the
cost of a step depends on the input's size, not its content.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time

import numpy as np
import torch

from ndrql.model.checkpoint import load_checkpoint, model_from_checkpoint
from ndrql.model.weights import resolve_weights
from ndrql.training.distributed import Precision, cpu_has_bf16
from ndrql.training.loop import train_step


def batch(side: int, size: int, seed: int = 0) -> tuple[torch.Tensor, ...]:
    """``size`` inputs of ``side`` px with region, guideline and distance labels of the right shapes."""
    rng = np.random.default_rng(seed)
    x = np.zeros((size, 3, side, side), np.float32)
    x[:, 0] = rng.random((size, side, side)) < 0.2
    x[:, 1, side // 8, side // 8] = 1.0
    x[:, 2, -side // 8, -side // 8] = 1.0
    region = np.zeros((size, 1, side, side), np.float32)
    region[:, :, side // 8: -side // 8, side // 8: side // 4] = 1.0
    guide = np.zeros_like(region)
    guide[:, :, side // 8: -side // 8, side // 8] = 1.0
    dist = np.stack([np.where(region[:, 0] > 0, rng.random((size, side, side)), -1.0),
                     np.tile(np.add.outer(np.arange(side), np.arange(side)) / 40.0, (size, 1, 1))], 1)
    return tuple(torch.from_numpy(a.astype(np.float32)) for a in (x, region, guide, dist))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--side", type=int, default=512, help="input side in px (a 128-cell grid is 512)")
    ap.add_argument("--batch", type=int, default=0, help="samples per step (0: what training uses at this side)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args()
    from ndrql.dataset.mixture import batch_size_for

    torch.set_num_threads(args.threads)
    size = args.batch or batch_size_for(args.side, 16)
    data = batch(args.side, size)
    ck = load_checkpoint(resolve_weights("general"))
    modes = {"fp32": Precision("cpu", None), "bf16": Precision("cpu", torch.bfloat16)}
    times: dict[str, list[float]] = {m: [] for m in modes}
    for _ in range(args.rounds):
        for name, precision in modes.items():
            net = model_from_checkpoint(ck).train()
            opt = torch.optim.AdamW(net.parameters(), lr=1e-5)
            train_step(net, opt, data, 1e-5, precision, distance_rank="raw+snapped")  # warm-up
            t0 = time.thread_time()
            train_step(net, opt, data, 1e-5, precision, distance_rank="raw+snapped")
            times[name].append(time.thread_time() - t0)
    med = {m: statistics.median(t) for m, t in times.items()}
    print(f"{platform.processor() or platform.machine()}, torch {torch.__version__}, {args.threads} thread(s), "
          f"native bf16: {cpu_has_bf16()}; side {args.side} px, batch {size}, {args.rounds} rounds")
    for m, t in times.items():
        print(f"{m}: median {med[m]:.2f} CPU s/step  [{min(t):.2f}..{max(t):.2f}]")
    print(f"bf16 / fp32: {med['bf16'] / med['fp32']:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
