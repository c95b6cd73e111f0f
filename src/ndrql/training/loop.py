"""Training loop with exact resume (SPEC section 5): AdamW, warmup + cosine, bf16 autocast on CPU.

State lives in a run directory outside git: ``last.pt`` (written atomically every few minutes and at
each epoch end, with the position inside the epoch), ``best.pt`` (best validation F1) and
``metrics.csv`` (one row per epoch). ``resume=True`` continues where ``last.pt`` stopped: same data
order, same schedule.
"""

from __future__ import annotations

import csv
import math
import os
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch

from ndrql.dataset.batches import train_batches
from ndrql.dataset.cache import load_split
from ndrql.dataset.splits import train_val_split
from ndrql.errors import CheckpointError
from ndrql.model.registry import build_model
from ndrql.training.checkpoint import load_checkpoint, save_checkpoint
from ndrql.training.config import TrainConfig
from ndrql.training.evaluate import evaluate
from ndrql.training.losses import ndr_loss


def learning_rate(cfg: TrainConfig, global_step: int, total_steps: int) -> float:
    """Linear warm-up then cosine decay to 1% of the peak."""
    if global_step < cfg.warmup_steps:
        return cfg.lr * (global_step + 1) / cfg.warmup_steps
    t = (global_step - cfg.warmup_steps) / max(1, total_steps - cfg.warmup_steps)
    return cfg.lr * (0.01 + 0.99 * 0.5 * (1 + math.cos(math.pi * min(1.0, t))))


def write_metrics_row(path: Path, row: dict) -> None:
    """Append one row to the metrics CSV (header written once); rewrite atomically."""
    rows = []
    if path.exists():
        with path.open() as f:
            rows = list(csv.DictReader(f))
    rows = [r for r in rows if int(r["epoch"]) != row["epoch"]] + [{k: str(v) for k, v in row.items()}]
    tmp = path.with_name(f".{path.name}.tmp")
    with tmp.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(row))
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, path)


def train(cfg: TrainConfig, run_dir: str | Path, resume: bool = False, progress: bool = True, log=print) -> dict:
    """Train (or resume) a model in ``run_dir``; returns the final state summary."""
    from tqdm import tqdm

    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    last_path, best_path = run_dir / "last.pt", run_dir / "best.pt"
    if cfg.threads:
        torch.set_num_threads(cfg.threads)
    train_data = load_split(cfg.data, "train", progress=progress)
    seen = load_split(cfg.data, "seen", progress=progress)
    tr_idx, val_idx = train_val_split(train_data, seen, cfg.val_fraction, cfg.seed)
    steps_per_epoch = len(tr_idx) // cfg.batch_size
    total_steps = steps_per_epoch * cfg.epochs

    model_cfg = cfg.model_config()
    model = build_model(model_cfg).to(memory_format=torch.channels_last)
    opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    state = {"epoch": 0, "step": 0, "global_step": 0, "best_f1": -1.0, "train_seconds": 0.0}
    if resume and last_path.exists():
        ck = load_checkpoint(last_path)
        saved = ck.get("train_config", {})
        if saved.get("model") != cfg.model or dict(ck["config"]) != model_cfg:
            raise CheckpointError(f"{last_path} was trained with model {saved.get('model')!r} / {ck['config']}; resume with the same --model")
        model.load_state_dict(ck["model"])
        opt.load_state_dict(ck["optimizer"])
        state.update(ck["state"])
        log(f"resumed from {last_path}: epoch {state['epoch']} step {state['step']} (global {state['global_step']})")
    elif last_path.exists():
        raise CheckpointError(f"{last_path} exists: pass --resume to continue it, or choose another --run-dir")

    def payload(extra: dict | None = None) -> dict:
        return {
            "config": model_cfg,
            "train_config": asdict(cfg),
            "model": model.state_dict(),
            "optimizer": opt.state_dict(),
            "state": dict(state),
            **(extra or {}),
        }

    last_save = time.monotonic()
    steps_this_call = 0
    while state["epoch"] < cfg.epochs:
        epoch = state["epoch"]
        model.train()
        bar = tqdm(total=steps_per_epoch, initial=state["step"], desc=f"epoch {epoch + 1}/{cfg.epochs}", disable=not progress, unit="step")
        loss_sum, loss_n = 0.0, 0
        epoch_t0 = time.perf_counter()
        for step, (x, region, guide) in train_batches(train_data, tr_idx, cfg.batch_size, cfg.seed, epoch, state["step"], cfg.augment, model_cfg["encoding"]):
            t0 = time.perf_counter()
            for group in opt.param_groups:
                group["lr"] = learning_rate(cfg, state["global_step"], total_steps)
            with torch.autocast("cpu", dtype=torch.bfloat16, enabled=cfg.bf16):
                r_logit, g_logit = model(x.contiguous(memory_format=torch.channels_last))
            loss = ndr_loss(r_logit, g_logit, region, guide)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            dt = time.perf_counter() - t0
            state["train_seconds"] += dt
            state["step"], state["global_step"] = step + 1, state["global_step"] + 1
            loss_sum, loss_n = loss_sum + float(loss.detach()), loss_n + 1
            bar.update(1)
            bar.set_postfix(loss=f"{loss_sum / loss_n:.3f}", sps=f"{cfg.batch_size / dt:.1f}")
            steps_this_call += 1
            if not progress and state["step"] % 50 == 0:
                log(f"epoch {epoch + 1} step {state['step']}/{steps_per_epoch} loss {loss_sum / loss_n:.4f} "
                    f"{cfg.batch_size * loss_n / max(1e-9, time.perf_counter() - epoch_t0):.1f} samples/s")
            if time.monotonic() - last_save > 60 * cfg.checkpoint_minutes:
                save_checkpoint(last_path, payload())
                last_save = time.monotonic()
            if cfg.max_steps and steps_this_call >= cfg.max_steps:
                save_checkpoint(last_path, payload())
                bar.close()
                return dict(state)
        bar.close()
        res = evaluate(model, train_data, val_idx, encoding=model_cfg["encoding"], bf16=cfg.bf16).summary()
        score = res["region_f1"] + (res["guideline_f1"] if np.isfinite(res["guideline_f1"]) else 0.0)
        state.update(epoch=epoch + 1, step=0)
        row = {"epoch": epoch + 1, "global_step": state["global_step"], "train_hours": round(state["train_seconds"] / 3600, 4),
               "train_loss": round(loss_sum / max(loss_n, 1), 5), "val_region_f1": round(res["region_f1"], 3),
               "val_guideline_f1": round(res["guideline_f1"], 3), "lr": learning_rate(cfg, state["global_step"], total_steps)}
        write_metrics_row(run_dir / "metrics.csv", row)
        log(f"epoch {epoch + 1}: loss {row['train_loss']} val region F1 {row['val_region_f1']} guideline F1 {row['val_guideline_f1']}")
        if score > state["best_f1"]:
            state["best_f1"] = score
            save_checkpoint(best_path, payload({"metrics": {"val": res, "epoch": epoch + 1}}))
        save_checkpoint(last_path, payload())
        last_save = time.monotonic()
    return dict(state)
