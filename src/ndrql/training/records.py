"""What a training run records per epoch: the ``metrics.csv`` rows and the score ``best.pt`` is chosen by."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ndrql.io import atomic_write


def val_score(res: dict[str, float]) -> float:
    """The score best.pt is chosen by: region F1 plus guideline F1 (0 when the model has no guideline)."""
    return res["region_f1"] + (res["guideline_f1"] if np.isfinite(res["guideline_f1"]) else 0.0)


def metrics_row(epoch: int, state: dict, train_loss: float, res: dict[str, float], lr: float) -> dict:
    """One metrics.csv row: epoch (0 = the starting weights of a warm start), progress, loss and validation."""
    row = {"epoch": epoch, "global_step": state["global_step"], "train_hours": round(state["train_seconds"] / 3600, 4),
           "train_loss": round(train_loss, 5), "val_region_f1": round(res["region_f1"], 3),
           "val_guideline_f1": round(res["guideline_f1"], 3), "lr": lr}
    row.update({k.replace("/", "_"): round(v, 3) for k, v in res.items() if "/" in k})
    return row


def write_metrics_row(path: Path, row: dict) -> None:
    """Append one row to the metrics CSV (header written once); rewrite it through :func:`ndrql.io.atomic_write`."""
    rows = []
    if path.exists():
        with path.open() as f:
            rows = list(csv.DictReader(f))
    rows = [r for r in rows if int(r["epoch"]) != row["epoch"]] + [{k: str(v) for k, v in row.items()}]

    def write(f) -> None:
        w = csv.DictWriter(f, fieldnames=list(row))
        w.writeheader()
        w.writerows(rows)

    atomic_write(path, write, mode="w")
