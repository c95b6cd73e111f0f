"""Train the propagation probe with the progressive loss of recurrent "thinking" networks.

    PYTHONPATH=src python studies/propagate/train.py DATA.npz OUT.pt --width 12 --minutes 12 --iters 60
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict

import numpy as np
import torch
import torch.nn.functional as F

from net import Propagator, inputs


def batches(data, batch: int, rng):
    by_n = defaultdict(list)
    for i, b in enumerate(data["blocked"]):
        by_n[b.shape[0]].append(i)
    keys = sorted(by_n)
    while True:
        n = keys[int(rng.integers(len(keys)))]
        idx = rng.choice(by_n[n], size=batch, replace=False)
        x = torch.stack([inputs(data["blocked"][i], tuple(data["start"][i]), tuple(data["goal"][i])) for i in idx])
        y = torch.stack([torch.as_tensor(data["route"][i], dtype=torch.float32) for i in idx])[:, None]
        yield n, x, y


def loss_of(logit, y, x, pos_weight: float = 5.0):
    free = x[:, :1]
    w = free * (1 + (pos_weight - 1) * y)
    return (F.binary_cross_entropy_with_logits(logit, y, reduction="none") * w).sum() / w.sum()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("data", help="one or more .npz files of data.py, joined by ':'")
    ap.add_argument("out")
    ap.add_argument("--width", type=int, default=12)
    ap.add_argument("--minutes", type=float, default=12)
    ap.add_argument("--iters", type=int, default=60, help="iterations per cell of the grid side / 48")
    ap.add_argument("--batch", type=int, default=24)
    ap.add_argument("--alpha", type=float, default=0.5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--init", default=None)
    ap.add_argument("--pool", action="store_true", help="the block also sees a 3x3 max of its state (net.py)")
    ap.add_argument("--lr", type=float, default=2e-3, help="peak learning rate, cosine-decayed over --minutes")
    ap.add_argument("--threads", type=int, default=0, help="torch threads (0: torch's default)")
    ap.add_argument("--pos-weight", type=float, default=5.0, help="weight of a route cell in the loss")
    a = ap.parse_args()
    torch.manual_seed(a.seed)
    if a.threads:
        torch.set_num_threads(a.threads)
    rng = np.random.default_rng(a.seed)
    parts = [np.load(f, allow_pickle=True) for f in a.data.split(":")]
    data = {k: [v for p in parts for v in p[k]] for k in ("blocked", "start", "goal", "route")}
    net = Propagator(a.width, a.pool)
    if a.init:
        net.load_state_dict(torch.load(a.init)["state"])
    opt = torch.optim.AdamW(net.parameters(), lr=a.lr, weight_decay=2e-4)
    t0, step, hist = time.time(), 0, []
    for n, x, y in batches(data, a.batch, rng):
        T = max(8, int(round(a.iters * n / 48)))
        logit, _ = net(x, T)
        loss = (1 - a.alpha) * loss_of(logit, y, x, a.pos_weight)
        if a.alpha > 0:
            m = int(rng.integers(0, T))
            k = int(rng.integers(1, T - m + 1))
            with torch.no_grad():
                _, h = net(x, m)
            logit2, _ = net(x, k, h.detach())
            loss = loss + a.alpha * loss_of(logit2, y, x, a.pos_weight)
        opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(net.parameters(), 2.0)
        for group in opt.param_groups:  # cosine decay over the time budget
            group["lr"] = a.lr * 0.5 * (1 + np.cos(np.pi * min(1.0, (time.time() - t0) / (a.minutes * 60))))
        opt.step()
        step += 1
        hist.append(float(loss.detach()))
        el = time.time() - t0
        if step % 50 == 0:
            print(f"step {step} {el/60:.1f} min loss {np.mean(hist[-50:]):.4f}", flush=True)
            torch.save({"state": net.state_dict(), "width": a.width, "pool": a.pool, "iters": a.iters, "step": step}, a.out)
        if el > a.minutes * 60:
            break
    torch.save({"state": net.state_dict(), "width": a.width, "pool": a.pool, "iters": a.iters, "step": step}, a.out)
    print("done", step, "steps")


if __name__ == "__main__":
    main()
