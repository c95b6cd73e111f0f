"""Score several weights on one training run's own validation inputs (region and guideline F1, distance order).

A warm-started run's validation F1 says nothing until it is compared with its starting weights on the
same inputs: this rebuilds the run's mixture from its checkpoint's ``train_config`` (same sources,
grids, view, split seed), draws the same validation items the loop scores each epoch, and evaluates
each weights file on them in fp32 (the loop's own precision on this CPU)::

    PYTHONPATH=src python studies/large_view/compare_val.py ~/.cache/ndrql/runs/large-spec \\
        src/ndrql/data/ndr_general.pt ~/.cache/ndrql/runs/large-spec/best.pt

Prints one row per weights file; nothing is written.
"""
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import torch

from ndrql.model.checkpoint import load_checkpoint, model_from_checkpoint
from ndrql.training.config import TrainConfig
from ndrql.training.evaluate import evaluate_rendered
from ndrql.training.loop import build_mixture


def run_config(run_dir: Path) -> TrainConfig:
    """The run's TrainConfig, read from ``last.pt`` (else ``best.pt``)."""
    for name in ("last.pt", "best.pt"):
        if (run_dir / name).exists():
            saved = load_checkpoint(run_dir / name)["train_config"]
            fields = {f.name for f in dataclasses.fields(TrainConfig)}
            return TrainConfig(**{k: v for k, v in saved.items() if k in fields})
    raise SystemExit(f"no last.pt or best.pt in {run_dir}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path, help="training run whose validation items are scored")
    ap.add_argument("weights", nargs="+", help="checkpoints or inference weights (.pt) to score")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    cfg = run_config(args.run_dir)
    mixture = build_mixture(cfg, progress=False)[0]
    items = mixture.validation(cfg.val_per_source)
    encoding = cfg.model_config().get("encoding") or "point"
    print(f"{len(items)} validation items of {cfg.sources} at grids {cfg.grid_sizes}, view {cfg.view}")
    for w in args.weights:
        model = model_from_checkpoint(load_checkpoint(w))
        res = evaluate_rendered(model, items, encoding, bf16=False)
        keys = ("region_f1", "guideline_f1", "distance_order/all", "distance_order_snapped/all")
        print(w, " ".join(f"{k} {res[k]:.2f}" for k in keys if k in res))


if __name__ == "__main__":
    main()
