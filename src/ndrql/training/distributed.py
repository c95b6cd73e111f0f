"""Devices, mixed precision and multi-process data parallelism (DDP under ``torchrun``) for training.

One code path for every setting: a single CPU process is the world of size 1, where nothing here
does any work beyond picking the device. Under ``torchrun`` (``RANK``/``WORLD_SIZE``/``LOCAL_RANK``
in the environment) each process joins a process group (gloo on CPU, NCCL on CUDA) and trains on a
disjoint shard of each epoch's samples.

**Data order.** Every rank draws the same epoch permutation from ``(seed, epoch)``
(:func:`ndrql.dataset.batches.epoch_order`) and keeps ``perm[rank::world_size]``; step ``s`` of
rank ``r`` takes ``batch_size`` consecutive items of that shard. The union over ranks of step ``s``
is then exactly ``perm[s * G:(s + 1) * G]`` with ``G = batch_size * world_size``: the *global
batch* of DDP with ``world_size`` ranks of ``batch_size`` samples equals the batch of a single
process with ``batch_size = G``, sample for sample (augmentation included). That is why a run can be
resumed under another world size when the global batch stays the same.
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass
from typing import Iterator

import numpy as np
import torch

from ndrql.dataset.batches import epoch_order, make_batch, train_batches
from ndrql.dataset.cache import SplitArrays
from ndrql.errors import NdrqlError

class DeviceError(NdrqlError, ValueError):
    """A device, precision or torchrun setting this machine cannot honour (one line on the CLI)."""


#: Devices ``--device`` accepts.
DEVICES = ("auto", "cpu", "cuda", "mps")
#: Autocast dtypes ``--amp-dtype`` accepts on CUDA.
AMP_DTYPES = ("auto", "bf16", "fp16")


@dataclass(frozen=True)
class World:
    """Where this process sits in the job: rank, local rank (GPU index on its node), world size."""

    rank: int = 0
    local_rank: int = 0
    world_size: int = 1

    @property
    def distributed(self) -> bool:
        """True when more than one process trains."""
        return self.world_size > 1

    @property
    def is_main(self) -> bool:
        """Rank 0 writes checkpoints, logs, metrics and progress bars."""
        return self.rank == 0


def world_from_env(env: dict | None = None) -> World:
    """The world ``torchrun`` describes in ``RANK``, ``LOCAL_RANK``, ``WORLD_SIZE`` (size 1 when absent)."""
    env = os.environ if env is None else env
    world_size = int(env.get("WORLD_SIZE", "1"))
    rank = int(env.get("RANK", "0"))
    local_rank = int(env.get("LOCAL_RANK", str(rank)))
    if world_size < 1 or not 0 <= rank < world_size:
        raise DeviceError(f"inconsistent torchrun environment: RANK={rank} WORLD_SIZE={world_size}")
    return World(rank=rank, local_rank=local_rank, world_size=world_size)


def resolve_device(name: str, world: World = World()) -> torch.device:
    """``--device`` -> torch.device; ``auto`` is CUDA when available, else the CPU.

    Under DDP with CUDA each process takes GPU ``LOCAL_RANK``. MPS is used only when asked for
    (its autocast and DDP support are incomplete) and is single-process only.
    """
    if name not in DEVICES:
        raise DeviceError(f"unknown device {name!r}; valid: {', '.join(DEVICES)}")
    if name == "auto":
        name = "cuda" if torch.cuda.is_available() else "cpu"
    if name == "cuda":
        if not torch.cuda.is_available():
            raise DeviceError("--device cuda: no CUDA device is visible to torch (torch.cuda.is_available() is False); use --device cpu")
        if world.local_rank >= torch.cuda.device_count():
            raise DeviceError(f"LOCAL_RANK {world.local_rank} but only {torch.cuda.device_count()} CUDA devices: lower --nproc-per-node")
        return torch.device("cuda", world.local_rank)
    if name == "mps":
        if not (getattr(torch.backends, "mps", None) and torch.backends.mps.is_available()):
            raise DeviceError("--device mps: the MPS backend is not available in this torch build/machine; use --device cpu")
        if world.distributed:
            raise DeviceError("DDP on MPS is not supported by torch; use --device cpu (gloo) for multi-process runs")
        return torch.device("mps")
    return torch.device("cpu")


@dataclass(frozen=True)
class Precision:
    """Mixed-precision policy of one device: the autocast dtype (None = fp32) and whether a GradScaler is needed."""

    device_type: str
    dtype: torch.dtype | None
    scaler: bool = False

    def autocast(self):
        """The autocast context for the forward pass (disabled for fp32)."""
        if self.dtype is None:
            return contextlib.nullcontext()
        return torch.autocast(self.device_type, dtype=self.dtype)

    def describe(self) -> str:
        """Short human-readable name, e.g. ``cuda fp16 + GradScaler``."""
        name = {None: "fp32", torch.bfloat16: "bf16", torch.float16: "fp16"}[self.dtype]
        return f"{self.device_type} {name}" + (" + GradScaler" if self.scaler else "")


def cpu_has_bf16() -> bool:
    """The CPU computes bf16 natively (AVX512-BF16 or AMX, as oneDNN reports it). Without it, bf16 autocast
    is emulated and slow: on the 2-core AVX2 EPYC of docs/training.md a training step of the half-width
    model at 512 px took 19.5 s under bf16 against 2.4 s in fp32."""
    try:
        return bool(torch.ops.mkldnn._is_mkldnn_bf16_supported())
    except (AttributeError, RuntimeError):  # a build without oneDNN: no native bf16 either
        return False


def precision_for(device: torch.device, mixed: bool = True, cuda_dtype: str = "auto") -> Precision:
    """Mixed precision per device: on the CPU bf16 autocast where the CPU has native bf16
    (:func:`cpu_has_bf16`), fp32 otherwise; on CUDA bf16 where the GPU supports it (``auto``) else fp16
    with a GradScaler; fp32 on MPS and whenever ``mixed`` is off."""
    if cuda_dtype not in AMP_DTYPES:
        raise DeviceError(f"unknown --amp-dtype {cuda_dtype!r}; valid: {', '.join(AMP_DTYPES)}")
    if not mixed or device.type == "mps":
        return Precision(device.type, None)
    if device.type == "cuda":
        if cuda_dtype == "auto":
            cuda_dtype = "bf16" if torch.cuda.is_bf16_supported() else "fp16"
        if cuda_dtype == "bf16":
            return Precision("cuda", torch.bfloat16)
        return Precision("cuda", torch.float16, scaler=True)
    return Precision("cpu", torch.bfloat16 if cpu_has_bf16() else None)


def init_process_group(world: World, device: torch.device) -> bool:
    """Join the torchrun job (gloo on CPU, NCCL on CUDA); False when there is nothing to join or it is joined."""
    import torch.distributed as dist

    if not world.distributed or dist.is_initialized():
        return False
    if device.type == "cuda":
        torch.cuda.set_device(device)
    backend = "nccl" if device.type == "cuda" else "gloo"
    kwargs = {"device_id": device} if device.type == "cuda" else {}
    dist.init_process_group(backend=backend, rank=world.rank, world_size=world.world_size, **kwargs)
    return True


def destroy_process_group() -> None:
    """Leave the process group (no-op when none)."""
    import torch.distributed as dist

    if dist.is_initialized():
        dist.destroy_process_group()


def barrier(world: World) -> None:
    """Wait for every rank (no-op for one process)."""
    if world.distributed:
        import torch.distributed as dist

        dist.barrier()


def all_reduce_sum(values: list[float], world: World, device: torch.device) -> list[float]:
    """Sum a few floats over the ranks (float64; returned unchanged for one process)."""
    if not world.distributed:
        return list(values)
    import torch.distributed as dist

    t = torch.tensor(values, dtype=torch.float64, device=device)
    dist.all_reduce(t, op=dist.ReduceOp.SUM)
    return t.tolist()


def shard_plan(n: int, batch_size: int, seed: int, epoch: int, world: World = World()) -> tuple[np.ndarray, np.ndarray, int]:
    """This rank's part of an epoch: positions into the sample list, their transform ids, and the steps per epoch.

    Same permutation on all ranks from ``(seed, epoch)``, then ``perm[rank::world_size]``; an epoch
    has ``n // (batch_size * world_size)`` steps (the last partial global batch is dropped).
    """
    perm, ks = epoch_order(n, seed, epoch)
    steps = n // (batch_size * world.world_size)
    return perm[world.rank::world.world_size], ks[world.rank::world.world_size], steps


def rank_batches(data: SplitArrays, indices: np.ndarray, batch_size: int, seed: int, epoch: int, start_step: int = 0,
                 augment: bool = True, encoding: str = "point", world: World = World()) -> Iterator[tuple[int, tuple[torch.Tensor, torch.Tensor, torch.Tensor]]]:
    """Yield ``(step, batch)`` of this rank for one epoch from ``start_step`` on.

    One process: exactly :func:`ndrql.dataset.batches.train_batches` (the single-process data order
    is unchanged). Several: this rank's shard (see :func:`shard_plan`).
    """
    if not world.distributed:
        yield from train_batches(data, indices, batch_size, seed, epoch, start_step, augment, encoding)
        return
    pos, ks, steps = shard_plan(len(indices), batch_size, seed, epoch, world)
    for step in range(start_step, steps):
        sel = slice(step * batch_size, (step + 1) * batch_size)
        yield step, make_batch(data, indices[pos[sel]], ks[sel] if augment else None, encoding)


class StepBatches(torch.utils.data.Dataset):
    """Map-style dataset whose item ``s`` is this rank's batch of step ``start_step + s`` (for a DataLoader
    with workers and pinned memory on GPU; the batch is built by :func:`make_batch`)."""

    def __init__(self, data: SplitArrays, indices: np.ndarray, batch_size: int, seed: int, epoch: int, start_step: int,
                 augment: bool, encoding: str, world: World):
        self.data, self.indices, self.batch_size = data, indices, batch_size
        self.augment, self.encoding, self.start_step = augment, encoding, start_step
        self.pos, self.ks, self.steps = shard_plan(len(indices), batch_size, seed, epoch, world)

    def __len__(self) -> int:
        return max(0, self.steps - self.start_step)

    def __getitem__(self, s: int):
        step = self.start_step + s
        sel = slice(step * self.batch_size, (step + 1) * self.batch_size)
        return make_batch(self.data, self.indices[self.pos[sel]], self.ks[sel] if self.augment else None, self.encoding)


def loader_batches(data: SplitArrays, indices: np.ndarray, batch_size: int, seed: int, epoch: int, start_step: int,
                   augment: bool, encoding: str, world: World, workers: int, pin: bool = True) -> Iterator[tuple[int, tuple[torch.Tensor, torch.Tensor, torch.Tensor]]]:
    """Like :func:`rank_batches` (same batches, same order), built by ``workers`` processes into pinned memory."""
    ds = StepBatches(data, indices, batch_size, seed, epoch, start_step, augment, encoding, world)
    loader = torch.utils.data.DataLoader(ds, batch_size=None, shuffle=False, num_workers=workers, pin_memory=pin,
                                         prefetch_factor=4 if workers else None, persistent_workers=False)
    for s, batch in enumerate(loader):
        yield start_step + s, batch
