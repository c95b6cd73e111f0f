"""Trained NDR runs for the model tables (1, 4 and sizing): where they live, how far they are, their F1.

Every score is the lead's evaluation (:func:`ndrql.training.evaluate.evaluate`, docs/method.md: threshold
0.5, per-image pixel F1, mean over the split) on TEST/SEEN and TEST/UNSEEN, cached per checkpoint
digest so a re-run only evaluates what changed. Training state lives in run directories under
``$NDRQL_CACHE/runs`` (outside git): ``rgp`` for Table 1's peer, ``table4/<variant>`` for Table 4,
``width/*`` and ``precision/*`` for the sizing comparison (``tools/train_comparisons.sh`` trains
them all, resumably).
"""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import torch

from ndrql.dataset.cache import cache_dir, load_split
from ndrql.io import file_digest, write_json
from ndrql.limits import env_number
from ndrql.model.checkpoint import load_checkpoint, model_from_checkpoint
from ndrql.training.evaluate import evaluate


def runs_root() -> Path:
    """``$NDRQL_CACHE/runs``: where ``ndrql train`` keeps run directories by default."""
    return cache_dir() / "runs"


def run_status(run_dir: Path) -> dict[str, Any] | None:
    """Where a run directory stands: its schedule, progress, time and best validation F1 (None if empty)."""
    last = run_dir / "last.pt"
    if not last.is_file():
        return None
    ck = load_checkpoint(last, note=False)
    st, tc = ck.get("state", {}), ck.get("train_config", {})
    out = {"epochs": int(tc.get("epochs", 0)), "epoch": int(st.get("epoch", 0)), "step": int(st.get("step", 0)),
           "global_step": int(st.get("global_step", 0)), "train_hours": float(st.get("train_seconds", 0.0)) / 3600,
           "model": tc.get("model"), "config": dict(ck["config"]), "bf16": bool(tc.get("bf16", True))}
    out["finished"] = out["epoch"] >= out["epochs"] > 0
    best = run_dir / "best.pt"
    out["weights"] = best if best.is_file() else last
    return out


def checkpoint_summary(path: Path) -> dict[str, Any]:
    """Parameters (M), epochs, optimiser steps and training hours recorded in a checkpoint."""
    ck = load_checkpoint(path)
    st, tc = ck.get("state", {}), ck.get("train_config", {})
    params = sum(v.numel() for k, v in ck["model"].items() if "running_" not in k and "num_batches" not in k)
    return {"params_m": params / 1e6, "epochs": int(st.get("epoch", tc.get("epochs", 0))),
            "steps": int(st.get("global_step", 0)), "train_hours": float(st.get("train_seconds", 0.0)) / 3600}


def read_metrics(run_dir: Path) -> list[dict[str, float]]:
    """The per-epoch rows of a run's ``metrics.csv`` (empty when there is none)."""
    path = run_dir / "metrics.csv"
    if not path.is_file():
        return []
    with path.open() as fh:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(fh)]


def evaluate_weights(path: str | Path, root: Path, limit: int | None, progress: bool,
                     cache: Path | None = None) -> dict[str, dict[str, float]]:
    """Mean F1 (percent) on seen and unseen for a checkpoint, cached in ``cache`` by file digest."""
    key = f"{file_digest(path)[:16]}-{limit or 'all'}"
    cached = cache / f"{key}.json" if cache is not None else None
    if cached is not None and cached.is_file():
        try:
            return json.loads(cached.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError):
            pass  # a damaged cache entry is recomputed
    torch.set_num_threads(env_number("NDRQL_EVAL_THREADS", 1))
    ck = load_checkpoint(path)
    model = model_from_checkpoint(ck)
    encoding = dict(ck["config"]).get("encoding", "point")
    out = {}
    for split in ("seen", "unseen"):
        data = load_split(root, split, progress=progress)
        idx = np.arange(min(len(data), limit)) if limit else None
        out[split] = evaluate(model, data, indices=idx, encoding=encoding, progress=progress).summary()
    if cached is not None:
        write_json(cached, out, indent=None, strict=False)
    return out
