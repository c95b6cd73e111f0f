"""``ndrql train``: train (or resume) an NDR model on the dataset.

Example::

    ndrql train --data path-planning-dataset --run-dir ~/.cache/ndrql/runs/ndr --epochs 8
    ndrql train --run-dir ~/.cache/ndrql/runs/ndr --resume      # continue after an interruption
    ndrql train --device cuda --model ndr-stdc1 --batch-size 32  # one GPU (auto picks CUDA when present)
    torchrun --standalone --nproc-per-node 4 -m ndrql train --model ndr-stdc1 --batch-size 8 --run-dir runs/ddp

Under torchrun --batch-size is per process: the global batch is batch-size x processes
(--scale-lr multiplies --lr by the number of processes). Only rank 0 writes files and prints.
A run resumes under any number of processes that keeps the global batch. See docs/training.md.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ndrql.cli.options import add_command, add_dataclass_options, dataclass_from_args
from ndrql.dataset.cache import cache_dir
from ndrql.dataset.layout import check_root, default_root
from ndrql.errors import CheckpointError
from ndrql.training.config import TrainConfig


def default_run_dir(model: str) -> Path:
    """``$NDRQL_CACHE/runs/<model>``: training state stays outside the repository."""
    return cache_dir() / "runs" / model


def register(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "train", help="train or resume an NDR model", description=__doc__)
    p.add_argument("--run-dir", type=Path, default=None, help="where checkpoints and metrics.csv go (default: $NDRQL_CACHE/runs/<model>)")
    p.add_argument("--resume", action="store_true", help="continue from <run-dir>/last.pt (same data order and schedule)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar (log lines only)")
    add_dataclass_options(p, TrainConfig)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ndrql.training.loop import train  # lazy: loads torch

    from ndrql.training.distributed import AMP_DTYPES, DEVICES, DeviceError, world_from_env  # lazy: loads torch

    cfg = dataclass_from_args(TrainConfig, args)
    if args.data is None and default_root() is not None:
        cfg = dataclass_from_args(TrainConfig, args, data=str(default_root()))
    if cfg.device not in DEVICES:
        raise DeviceError(f"unknown --device {cfg.device!r}; valid: {', '.join(DEVICES)}")
    if cfg.amp_dtype not in AMP_DTYPES:
        raise DeviceError(f"unknown --amp-dtype {cfg.amp_dtype!r}; valid: {', '.join(AMP_DTYPES)}")
    from ndrql.model.registry import check_config  # lazy: loads torch

    check_config(cfg.model_config())  # an unknown --model or a bad override: one line before any work
    from ndrql.dataset.mixture import parse_families  # lazy: loads scipy

    parse_families(cfg.exclude_families)  # an unknown family: the same
    if cfg.sources:
        from ndrql.dataset.generated import check_training_dir  # lazy: loads scipy
        from ndrql.dataset.mixture import parse_sources  # lazy: loads scipy

        for src in parse_sources(cfg.sources):  # a set drawn from an evaluation seed: one line before any work
            if src.name != "paper":
                check_training_dir(src.name)
    run_dir = args.run_dir or default_run_dir(cfg.model)
    if args.resume and not (run_dir / "last.pt").is_file():  # the loop says the same; here before the data loads
        raise CheckpointError(f"--resume: there is no {run_dir / 'last.pt'} to continue; drop --resume to start a new run")
    check_root(cfg.data)
    if world_from_env().is_main:
        print(f"run directory: {run_dir}", flush=True)
    train(cfg, run_dir, resume=args.resume, progress=not args.no_progress, log=lambda m: print(m, flush=True))
    return 0
