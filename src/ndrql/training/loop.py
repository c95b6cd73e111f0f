"""Training loop with exact resume (docs/method.md): AdamW, warmup + cosine, mixed precision per device,
one process or many (DDP under ``torchrun``; see :mod:`ndrql.training.distributed` and docs/training.md).

State lives in a run directory outside git: ``last.pt`` (written atomically every few minutes and at
each epoch end, with the position inside the epoch), ``best.pt`` (best validation F1) and
``metrics.csv`` (one row per epoch). ``resume=True`` continues where ``last.pt`` stopped: same data
order, same schedule.

Under DDP ``--batch-size`` is per process, so the global batch is ``batch_size x world_size`` and an
epoch has ``n // global_batch`` steps; the schedule counts those global steps. Only rank 0 writes
files, logs and shows progress; every rank holds the same weights. The weights are saved from the
unwrapped model (no ``module.`` prefix), so checkpoints move freely between one process and many.
A run resumes under any world size that keeps the same global batch (e.g. 1 x 16 <-> 2 x 8), with
exactly the batches it would have seen.
"""

from __future__ import annotations

import contextlib
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch
from torch import nn

from ndrql.dataset.cache import load_split
from ndrql.dataset.splits import train_val_split
from ndrql.dataset.views import GridView
from ndrql.errors import CheckpointError
from ndrql.io import folder_lock, make_folder
from ndrql.model.registry import build_model
from ndrql.training import distributed as D
from ndrql.model.checkpoint import load_checkpoint, save_checkpoint
from ndrql.training.config import TrainConfig
from ndrql.training.evaluate import evaluate, evaluate_rendered
from ndrql.training.records import metrics_row, val_score, write_metrics_row
from ndrql.training.losses import ndr_loss, unknown_pixel_weight
from ndrql.training.start import freeze_except, warm_start


def learning_rate(cfg: TrainConfig, global_step: int, total_steps: int, peak: float | None = None) -> float:
    """Linear warm-up then cosine decay to 1% of the peak (``cfg.lr`` unless ``peak`` is given)."""
    peak = cfg.lr if peak is None else peak
    if global_step < cfg.warmup_steps:
        return peak * (global_step + 1) / cfg.warmup_steps
    t = (global_step - cfg.warmup_steps) / max(1, total_steps - cfg.warmup_steps)
    return peak * (0.01 + 0.99 * 0.5 * (1 + math.cos(math.pi * min(1.0, t))))


def peak_lr(cfg: TrainConfig, world_size: int) -> float:
    """``--lr``, times the world size when ``--scale-lr`` asks for the linear scaling rule."""
    return cfg.lr * world_size if cfg.scale_lr else cfg.lr


def train_step(net: nn.Module, opt: torch.optim.Optimizer, batch: tuple[torch.Tensor, torch.Tensor, torch.Tensor], lr: float,
               precision: D.Precision, scaler: torch.amp.GradScaler | None = None, distance_rank: str = "raw",
               unknown_weight: float = 0.0) -> torch.Tensor:
    """One optimisation step on one batch (``net`` may be DDP-wrapped: its backward all-reduces the gradients);
    ``distance_rank``: the distance loss's ranking term (:data:`ndrql.training.config.RANK_ON`); ``unknown_weight``:
    the extra loss weight of the pixels the input's unknown channel marks (:func:`unknown_pixel_weight`)."""
    x, region, guide, *dist_target = batch
    for group in opt.param_groups:
        group["lr"] = lr
    with precision.autocast():
        r_logit, g_logit, *dist = net(x.contiguous(memory_format=torch.channels_last))
    loss = ndr_loss(r_logit, g_logit, region, guide, dist[0] if dist else None, dist_target[0] if dist_target else None,
                    rank_on=distance_rank, pixel_weight=unknown_pixel_weight(x, unknown_weight, tuple(region.shape[-2:])))
    opt.zero_grad(set_to_none=True)
    if scaler is not None:
        scaler.scale(loss).backward()
        scaler.step(opt)
        scaler.update()
    else:
        loss.backward()
        opt.step()
    return loss.detach()


class _OnDevice(nn.Module):
    """Evaluation adapter: CPU batches in, model on ``device`` under its autocast, float CPU outputs back
    (so :func:`ndrql.training.evaluate.evaluate`, which works on CPU tensors, serves GPU models too)."""

    def __init__(self, model: nn.Module, device: torch.device, precision: D.Precision):
        super().__init__()
        self.model, self.device, self.precision = model, device, precision

    def forward(self, x: torch.Tensor):
        with self.precision.autocast():
            r, g, *rest = self.model(x.to(self.device, non_blocking=True))
        return (r.float().cpu(), (g.float().cpu() if g is not None else None)) + tuple(t.float().cpu() for t in rest)


def validate(model: nn.Module, data, val_idx: np.ndarray, encoding: str, cfg: TrainConfig, device: torch.device,
             precision: D.Precision, world: D.World) -> dict[str, float]:
    """Validation F1 summary (percent). One process: ``evaluate(...).summary()``. DDP: each rank evaluates
    ``val_idx[rank::world_size]`` and the per-image F1 sums are all-reduced, giving the same means."""
    net = model if device.type == "cpu" else _OnDevice(model, device, precision)
    bf16 = device.type == "cpu" and precision.dtype is not None  # emulated bf16 (no native support) is slower
    if not world.distributed:
        return evaluate(net, data, val_idx, encoding=encoding, bf16=bf16).summary()
    shard = val_idx[world.rank::world.world_size]
    sums = [0.0, 0.0, 0.0, 0.0, 0.0]
    if len(shard):
        res = evaluate(net, data, shard, encoding=encoding, bf16=bf16)
        finite = np.isfinite(res.guideline_f1)
        sums = [res.region_f1.sum(), res.guideline_f1[finite].sum(), finite.sum(), res.region_f1_original.sum(), len(shard)]
    r, g, g_n, ro, n = D.all_reduce_sum([float(v) for v in sums], world, device)
    return {"region_f1": 100 * r / max(n, 1), "guideline_f1": 100 * g / g_n if g_n else float("nan"), "region_f1_original": 100 * ro / max(n, 1)}


def _sync_buffers(model: nn.Module, world: D.World) -> None:
    """Give every rank rank 0's buffers (BatchNorm running statistics), as DDP does before each forward."""
    if world.distributed:
        import torch.distributed as dist

        for buf in model.buffers():
            dist.broadcast(buf, 0)


def _on_rank0(world: D.World, fn):
    """Run ``fn`` on rank 0 and hand its result (or its error) to every rank."""
    if not world.distributed:
        return fn()
    import torch.distributed as dist

    box: list = [None]
    if world.is_main:
        try:
            box[0] = ("ok", fn())
        except Exception as exc:  # re-raised on every rank below
            box[0] = ("err", exc)
    dist.broadcast_object_list(box, src=0)
    kind, value = box[0]
    if kind == "err":
        raise value
    return value


def build_mixture(cfg: TrainConfig, progress: bool):
    """The mixture of ``cfg.sources`` (:mod:`ndrql.dataset.mixture`); returns (mixture, train ids, val ids, paper data)."""
    # lazy: loads scipy
    from ndrql.dataset.mixture import (MAX_SIZE, MAX_VIEW_SIZE, Mixture, generated_source, paper_source, parse_families,
                                       parse_sizes, parse_sources)

    sources, paper = [], None
    for spec in parse_sources(cfg.sources):
        if spec.name == "paper":
            paper = load_split(cfg.data, "train", progress=progress)
            seen = load_split(cfg.data, "seen", progress=progress)
            tr, va = train_val_split(paper, seen, cfg.val_fraction, cfg.seed)
            sources.append(paper_source(spec, paper, tr, va))
        else:
            sources.append(generated_source(spec, exclude=parse_families(cfg.exclude_families)))
    encoding = cfg.model_config().get("encoding") or "point"
    view = GridView.parse(cfg.view) if cfg.input_mode == "grid" and cfg.view != "native" else None
    sizes = parse_sizes(cfg.grid_sizes, MAX_SIZE if view is None else MAX_VIEW_SIZE)
    mixture = Mixture(sources, cfg.input_mode, sizes, encoding, distance=cfg.distance_head, view=view)
    tr_ids = np.concatenate([s.train_ids for s in sources])
    va_ids = np.concatenate([s.val_ids for s in sources])
    return mixture, tr_ids, va_ids, paper


@dataclass
class TrainOutcome:
    """What a training call leaves: the state summary, the (unwrapped) model, and this rank's per-step losses."""

    state: dict
    model: nn.Module
    losses: list[float] = field(default_factory=list)


def train(cfg: TrainConfig, run_dir: str | Path, resume: bool = False, progress: bool = True, log=print) -> dict:
    """Train (or resume) a model in ``run_dir``; returns the final state summary."""
    return run_training(cfg, run_dir, resume, progress, log).state


def run_training(cfg: TrainConfig, run_dir: str | Path, resume: bool = False, progress: bool = True, log=print) -> TrainOutcome:
    """:func:`train`, also returning the model and per-step losses. Joins the torchrun job when the
    environment describes one (and leaves it at the end)."""
    world = D.world_from_env()
    device = D.resolve_device(cfg.device, world)
    joined = D.init_process_group(world, device)
    try:
        with folder_lock(run_dir, "run folder") if world.is_main else contextlib.nullcontext():  # one training a folder
            return _run(cfg, Path(run_dir), resume, progress, log, world, device)
    finally:
        if joined:
            D.destroy_process_group()


def _run(cfg: TrainConfig, run_dir: Path, resume: bool, progress: bool, log, world: D.World, device: torch.device) -> TrainOutcome:
    from tqdm import tqdm

    main = world.is_main
    progress = progress and main
    if not main:
        log = lambda *_a, **_k: None  # noqa: E731 - only rank 0 talks
    last_path, best_path = run_dir / "last.pt", run_dir / "best.pt"
    if resume and not last_path.is_file():
        raise CheckpointError(f"--resume: there is no {last_path} to continue; drop --resume to start a new run")
    if main:
        make_folder(run_dir)
    if cfg.threads:
        torch.set_num_threads(cfg.threads)
    if device.type == "cuda":
        torch.backends.cudnn.benchmark = True

    # Data: the first process of each node builds the cache when it is missing, the others wait.
    mixture = None
    if cfg.sources:
        if world.distributed:
            raise D.DeviceError("--sources (mixture training) runs in one process; drop torchrun")
        mixture, tr_idx, val_idx, train_data = build_mixture(cfg, progress)
    else:
        if world.local_rank != 0:
            D.barrier(world)
        train_data = load_split(cfg.data, "train", progress=progress)
        seen = load_split(cfg.data, "seen", progress=progress)
        if world.local_rank == 0:
            D.barrier(world)
        tr_idx, val_idx = train_val_split(train_data, seen, cfg.val_fraction, cfg.seed)
    global_batch = cfg.batch_size * world.world_size
    steps_per_epoch = len(tr_idx) // global_batch
    if mixture is not None and cfg.steps_per_epoch:
        steps_per_epoch = cfg.steps_per_epoch
    total_steps = steps_per_epoch * cfg.epochs
    peak = peak_lr(cfg, world.world_size)

    model_cfg = cfg.model_config()
    encoding = model_cfg.get("encoding") or cfg.encoding or "point"
    with torch.random.fork_rng(devices=[]):  # initial weights from the seed, global RNG untouched
        torch.manual_seed(cfg.seed)
        model = build_model(model_cfg)
    if cfg.init_weights and not (resume and last_path.exists()):
        warm_start(model, cfg.init_weights, model_cfg)
        log(f"warm start from {cfg.init_weights}")
    model = model.to(device, memory_format=torch.channels_last)
    frozen = freeze_except(model, cfg.train_only)
    opt = torch.optim.AdamW([p for p in model.parameters() if p.requires_grad], lr=cfg.lr, weight_decay=cfg.weight_decay)
    if cfg.sync_bn and device.type != "cuda":
        raise D.DeviceError("--sync-bn needs CUDA (torch's SyncBatchNorm has no CPU/MPS kernel); drop it on this device")
    precision = D.precision_for(device, cfg.bf16, cfg.amp_dtype)
    scaler = torch.amp.GradScaler(device.type) if precision.scaler else None
    state = {"epoch": 0, "step": 0, "global_step": 0, "best_f1": -1.0, "train_seconds": 0.0}

    def read_last():
        if resume and last_path.exists():
            return load_checkpoint(last_path, note=False)
        if last_path.exists():
            raise CheckpointError(f"{last_path} exists: pass --resume to continue it, or choose another --run-dir")
        return None

    ck = _on_rank0(world, read_last)  # rank 0 reads; the run directory need not be shared between nodes
    if ck is not None:
        saved = ck.get("train_config", {})
        if saved.get("model") != cfg.model or dict(ck["config"]) != model_cfg:
            raise CheckpointError(f"{last_path} was trained with model {saved.get('model')!r} / {ck['config']}; resume with the same --model")
        saved_world = int(ck["state"].get("world_size", 1))
        saved_global = int(ck["state"].get("global_batch", int(saved.get("batch_size", cfg.batch_size)) * saved_world))
        if saved_global != global_batch:
            raise CheckpointError(
                f"{last_path} was trained with a global batch of {saved_global} ({saved_global // saved_world} x {saved_world} processes); "
                f"this run has {global_batch} ({cfg.batch_size} x {world.world_size}): set --batch-size {saved_global // world.world_size}"
                if saved_global % world.world_size == 0 else
                f"{last_path} was trained with a global batch of {saved_global}, which {world.world_size} processes cannot split evenly"
            )
        model.load_state_dict(ck["model"])
        opt.load_state_dict(ck["optimizer"])
        if scaler is not None and "scaler" in ck:
            scaler.load_state_dict(ck["scaler"])
        state.update(ck["state"])
        log(f"resumed from {last_path}: epoch {state['epoch']} step {state['step']} (global {state['global_step']})"
            + (f", trained so far on {saved_world} process(es)" if saved_world != world.world_size else ""))
        del ck
    state.update(world_size=world.world_size, global_batch=global_batch)
    if world.distributed:
        from torch.nn.parallel import DistributedDataParallel

        if cfg.sync_bn:  # same parameter and buffer names, so checkpoints stay interchangeable
            model = nn.SyncBatchNorm.convert_sync_batchnorm(model)
        net = DistributedDataParallel(model, device_ids=[device.index] if device.type == "cuda" else None)
        log(f"DDP: {world.world_size} processes ({'nccl' if device.type == 'cuda' else 'gloo'}), {cfg.batch_size} per process, "
            f"global batch {global_batch}, peak lr {peak:g}, {precision.describe()}")
    else:
        net = model
        log(f"device {device}, {precision.describe()}"
            + (" (this CPU has no native bf16: emulated bf16 would be several times slower)"
               if device.type == "cpu" and cfg.bf16 and precision.dtype is None else ""))

    def payload(extra: dict | None = None) -> dict:
        return {
            "config": model_cfg,
            "train_config": asdict(cfg),
            "model": model.state_dict(),
            "optimizer": opt.state_dict(),
            "state": dict(state),
            **({"scaler": scaler.state_dict()} if scaler is not None else {}),
            **(extra or {}),
        }

    def batches(epoch: int):
        if mixture is not None:
            return mixture.batches(cfg.seed, epoch, steps_per_epoch, cfg.batch_size, state["step"], cfg.augment)
        args = (train_data, tr_idx, cfg.batch_size, cfg.seed, epoch, state["step"], cfg.augment, encoding)
        if device.type == "cpu":
            return D.rank_batches(*args, world=world)
        return D.loader_batches(*args, world=world, workers=cfg.loader_workers, pin=device.type == "cuda")

    val_items = None

    def score_now() -> dict[str, float]:
        nonlocal val_items
        if mixture is not None:
            if val_items is None:
                val_items = mixture.validation(cfg.val_per_source)
            return evaluate_rendered(model, val_items, encoding, bf16=device.type == "cpu" and precision.dtype is not None)
        return validate(model, train_data, val_idx, encoding, cfg, device, precision, world)

    if cfg.init_weights and state["global_step"] == 0:
        # A warm start is judged against its starting point: the same validation inputs, before any step.
        res = score_now()
        state["start_f1"] = val_score(res)
        if main:
            write_metrics_row(run_dir / "metrics.csv", metrics_row(0, state, float("nan"), res, 0.0))
        log(f"starting weights: val region F1 {res['region_f1']:.3f} guideline F1 {res['guideline_f1']:.3f}")

    losses: list[float] = []
    last_save = time.monotonic()
    steps_this_call = 0
    while state["epoch"] < cfg.epochs:
        epoch = state["epoch"]
        model.train()
        for m in frozen:
            m.eval()  # fixed parts keep their BatchNorm statistics
        bar = tqdm(total=steps_per_epoch, initial=state["step"], desc=f"epoch {epoch + 1}/{cfg.epochs}", disable=not progress, unit="step")
        loss_sum, loss_n = 0.0, 0
        epoch_t0 = time.perf_counter()
        for step, batch in batches(epoch):
            t0 = time.perf_counter()
            if device.type != "cpu":
                batch = tuple(t.to(device, non_blocking=True) for t in batch)
            loss_t = train_step(net, opt, batch, learning_rate(cfg, state["global_step"], total_steps, peak), precision, scaler,
                                cfg.distance_rank, cfg.unknown_weight)
            dt = time.perf_counter() - t0
            loss = float(loss_t)
            state["train_seconds"] += dt
            state["step"], state["global_step"] = step + 1, state["global_step"] + 1
            loss_sum, loss_n = loss_sum + loss, loss_n + 1
            losses.append(loss)
            bar.update(1)
            bar.set_postfix(loss=f"{loss_sum / loss_n:.3f}", sps=f"{global_batch / dt:.1f}")
            steps_this_call += 1
            if not progress and state["step"] % 50 == 0:
                log(f"epoch {epoch + 1} step {state['step']}/{steps_per_epoch} loss {loss_sum / loss_n:.4f} "
                    f"{global_batch * loss_n / max(1e-9, time.perf_counter() - epoch_t0):.1f} samples/s")
            if main and time.monotonic() - last_save > 60 * cfg.checkpoint_minutes:
                save_checkpoint(last_path, payload())
                last_save = time.monotonic()
            if cfg.max_steps and steps_this_call >= cfg.max_steps:
                bar.close()
                _sync_buffers(model, world)
                if main:
                    save_checkpoint(last_path, payload())
                D.barrier(world)
                return TrainOutcome(dict(state), model, losses)
        bar.close()
        _sync_buffers(model, world)  # every rank validates with rank 0's BatchNorm statistics
        res = score_now()
        loss_sum, loss_n = D.all_reduce_sum([loss_sum, loss_n], world, device)
        score = val_score(res)
        state.update(epoch=epoch + 1, step=0)
        row = metrics_row(epoch + 1, state, loss_sum / max(loss_n, 1), res,
                          learning_rate(cfg, state["global_step"], total_steps, peak))
        if main:
            write_metrics_row(run_dir / "metrics.csv", row)
        start = state.get("start_f1")
        log(f"epoch {epoch + 1}: loss {row['train_loss']} val region F1 {row['val_region_f1']} guideline F1 {row['val_guideline_f1']}"
            + (f" (below the starting weights' {start:.3f})" if start is not None and score < start else ""))
        if score > state["best_f1"]:
            state["best_f1"] = score
            if main:
                save_checkpoint(best_path, payload({"metrics": {"val": res, "epoch": epoch + 1}}))
        if main:
            save_checkpoint(last_path, payload())
        last_save = time.monotonic()
    start = state.get("start_f1")
    if start is not None and state["best_f1"] < start:
        log(f"no epoch beat the starting weights on validation ({state['best_f1']:.3f} < {start:.3f}, region + guideline F1): "
            f"best.pt is the best epoch, not better than {cfg.init_weights}")
    D.barrier(world)
    return TrainOutcome(dict(state), model, losses)

