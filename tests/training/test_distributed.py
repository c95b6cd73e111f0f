"""Multi-process training (DDP, gloo, 2 processes on this CPU) against single-process training.

The data is a tiny synthetic dataset: empty folders in the original layout (enough for
``check_root``) and the decoded cache ``.npz`` files that ``ndrql.dataset.cache.load_split`` reads,
written straight into ``$NDRQL_CACHE`` (a temporary directory). The model is the quarter-width NDR
with a thin context/fusion/UNet, so a step takes a fraction of a second.

**Why the reference emulates per-rank BatchNorm.** Under DDP each rank normalises with the
statistics of *its own* part of the global batch, and the gradients are averaged. A single process
on the whole global batch normalises with the statistics of all of it, so its loss differs (by a
lot on batches of 2). The single-process reference below therefore feeds the same global batch as
the two rank shards it is made of (``x[r::2]``, exactly the samples rank ``r`` gets), averages
the two losses and steps once: that is DDP's arithmetic, in one process, with no collective. Its
per-step losses and final weights must match the DDP run up to float rounding. The reference runs
with the ranks' thread count: on batches of 2 this network amplifies rounding differences quickly
(BatchNorm over two pooled values), and 1 vs 2 intra-op threads alone moves the third step's loss
by ~1 %; with the same thread count the losses agree to ~1e-7.
"""

from __future__ import annotations

import dataclasses
import os
import socket
from pathlib import Path

import numpy as np
import pytest
import torch
import torch.multiprocessing as mp

from ndrql.dataset import layout
from ndrql.maps.grid import MODEL_SIDE
from ndrql.dataset.batches import train_batches
from ndrql.dataset.cache import cache_path, load_split, pack
from ndrql.dataset.splits import train_val_split
from ndrql.errors import CheckpointError
from ndrql.training import distributed as D
from ndrql.model.checkpoint import load_checkpoint, model_from_checkpoint
from ndrql.training.config import TrainConfig

from helpers.cli import assert_one_line_error, run_cli

TINY = {"unet_base": 4, "context_channels": 16, "fusion_channels": [16, 8]}
N_MAPS, N_TRAIN, N_SEEN = 20, 40, 4


def write_synthetic_dataset(root: Path, seed: int = 0) -> Path:
    """A dataset root that passes ``check_root`` plus cache files for TRAIN and SEEN (env NDRQL_CACHE set by the caller)."""
    for folder in layout.SPLITS.values():
        (root / folder / layout.MAP_DIR).mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    side = MODEL_SIDE
    maps = rng.random((N_MAPS, side, side)) < 0.1  # distinct random maps: each its own validation group

    def split_arrays(n: int, map_index: np.ndarray, maps_: np.ndarray) -> dict:
        points = rng.integers(0, side, size=(n, 4)).astype(np.int16)
        guide = np.zeros((n, side, side), bool)
        for i, (sr, sc, gr, gc) in enumerate(points):  # an L-shaped "path" from start to goal
            guide[i, min(sr, gr):max(sr, gr) + 1, sc] = True
            guide[i, gr, min(sc, gc):max(sc, gc) + 1] = True
        region = np.stack([layout.dilate_region(g) for g in guide])
        return {"maps": pack(maps_), "map_index": map_index.astype(np.int32), "points": points, "guideline": pack(guide),
                "region": pack(region), "region_original": pack(region), "category": (np.arange(n) % 4).astype(np.int8)}

    train = split_arrays(N_TRAIN, np.arange(N_TRAIN) % N_MAPS, maps)
    seen = split_arrays(N_SEEN, np.arange(N_SEEN), maps[:N_SEEN])  # SEEN maps are TRAIN maps, as in the real data
    for split, arrays in (("train", train), ("seen", seen)):
        path = cache_path(root, split)
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, **arrays)
    return root


@pytest.fixture()
def synthetic(tmp_path, monkeypatch) -> Path:
    cache = tmp_path / "cache"
    monkeypatch.setenv("NDRQL_CACHE", str(cache))
    for var in ("RANK", "WORLD_SIZE", "LOCAL_RANK"):
        monkeypatch.delenv(var, raising=False)
    return write_synthetic_dataset(tmp_path / "ds")


def tiny_config(root: Path, **kw) -> TrainConfig:
    base = dict(data=str(root), model="ndr-stdc1-quarter", model_overrides=TINY, epochs=2, batch_size=2, lr=5e-3,
                warmup_steps=2, val_fraction=0.1, device="cpu", bf16=False, augment=False, threads=1, checkpoint_minutes=60.0)
    base.update(kw)
    return TrainConfig(**base)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _worker(rank: int, world_size: int, port: int, cache: str, cfg: TrainConfig, run_dir: str, resume: bool, out: str) -> None:
    """One DDP rank: the torchrun environment by hand, then the real training call; dumps weights and losses."""
    os.environ.update(RANK=str(rank), LOCAL_RANK=str(rank), WORLD_SIZE=str(world_size), MASTER_ADDR="127.0.0.1",
                      MASTER_PORT=str(port), NDRQL_CACHE=cache, OMP_NUM_THREADS="1")
    from ndrql.training.loop import run_training

    res = run_training(cfg, run_dir, resume=resume, progress=False, log=lambda m: None)
    torch.save({"state": res.state, "losses": res.losses, "params": {k: v.detach().clone() for k, v in res.model.state_dict().items()}},
               Path(out) / f"rank{rank}.pt")


def run_ddp(cfg: TrainConfig, run_dir: Path, out: Path, resume: bool = False, world_size: int = 2) -> list[dict]:
    out.mkdir(parents=True, exist_ok=True)
    mp.spawn(_worker, args=(world_size, free_port(), os.environ["NDRQL_CACHE"], cfg, str(run_dir), resume, str(out)),
             nprocs=world_size, join=True)
    return [torch.load(out / f"rank{r}.pt", weights_only=False) for r in range(world_size)]


# --- data order ---------------------------------------------------------------------------------

@pytest.mark.parametrize("world_size", [2, 3, 4])
def test_rank_shards_make_up_the_single_process_global_batch(world_size):
    n, b, seed, epoch = 103, 4, 7, 3
    plans = [D.shard_plan(n, b, seed, epoch, D.World(rank=r, world_size=world_size)) for r in range(world_size)]
    steps = plans[0][2]
    assert steps == n // (b * world_size)
    g = b * world_size
    perm, ks = D.epoch_order(n, seed, epoch)
    for s in range(steps):
        got = np.concatenate([p[0][s * b:(s + 1) * b] for p in plans])
        got_k = np.concatenate([p[1][s * b:(s + 1) * b] for p in plans])
        order = np.argsort(got)
        ref = perm[s * g:(s + 1) * g]
        assert np.array_equal(got[order], np.sort(ref))  # same samples ...
        assert np.array_equal(got_k[order], ks[s * g:(s + 1) * g][np.argsort(ref)])  # ... with the same augmentation
    every = np.concatenate([p[0][:steps * b] for p in plans])
    assert len(set(every.tolist())) == len(every)  # disjoint shards
    other = D.shard_plan(n, b, seed, epoch + 1, D.World(rank=0, world_size=world_size))[0]
    assert not np.array_equal(other, plans[0][0])  # reshuffled every epoch


def test_world_of_one_is_the_single_process_order(synthetic):
    data = load_split(synthetic, "train", build=False, progress=False)
    idx = np.arange(len(data))
    a = list(D.rank_batches(data, idx, 4, 0, 1, 2, True, "point"))
    b = list(train_batches(data, idx, 4, 0, 1, 2, True, "point"))
    assert [s for s, _ in a] == [s for s, _ in b] == list(range(2, len(idx) // 4))
    for (_, x), (_, y) in zip(a, b):
        assert all(torch.equal(u, v) for u, v in zip(x, y))


@pytest.mark.parametrize("workers", [0, 1])
def test_gpu_loader_yields_the_same_batches(synthetic, workers):
    """The DataLoader path (workers, pinned memory on GPU) gives this rank the batches of the inline path."""
    data = load_split(synthetic, "train", build=False, progress=False)
    idx = np.arange(len(data))
    world = D.World(rank=1, local_rank=1, world_size=2)
    a = list(D.rank_batches(data, idx, 3, 5, 2, 1, True, "point", world=world))
    b = list(D.loader_batches(data, idx, 3, 5, 2, 1, True, "point", world=world, workers=workers, pin=False))
    assert [s for s, _ in a] == [s for s, _ in b] == list(range(1, len(idx) // 6))
    for (_, x), (_, y) in zip(a, b):
        assert all(torch.equal(u, v) for u, v in zip(x, y))


def test_device_and_precision_choices():
    assert D.resolve_device("cpu") == torch.device("cpu")
    assert D.resolve_device("auto") == torch.device("cuda" if torch.cuda.is_available() else "cpu")
    with pytest.raises(ValueError, match="valid: auto, cpu, cuda, mps"):
        D.resolve_device("tpu")
    if not torch.cuda.is_available():
        with pytest.raises(ValueError, match="no CUDA device"):
            D.resolve_device("cuda")
    cpu = D.precision_for(torch.device("cpu")).dtype
    assert cpu == (torch.bfloat16 if D.cpu_has_bf16() else None)  # emulated bf16 is slower than fp32
    assert D.precision_for(torch.device("cpu"), mixed=False).dtype is None
    fp16 = D.precision_for(torch.device("cuda", 0), cuda_dtype="fp16")
    assert fp16.dtype == torch.float16 and fp16.scaler
    assert D.world_from_env({"RANK": "1", "WORLD_SIZE": "4", "LOCAL_RANK": "1"}) == D.World(1, 1, 4)
    assert D.world_from_env({}) == D.World(0, 0, 1)


# --- DDP for real: gloo, 2 processes --------------------------------------------------------------

def reference_losses(cfg: TrainConfig, root: Path, steps: int, world_size: int) -> tuple[list[float], dict]:
    """Single process, global batch ``batch_size * world_size``, BatchNorm per rank shard (see module docstring)."""
    from ndrql.model.registry import build_model
    from ndrql.training.losses import ndr_loss
    from ndrql.training.loop import learning_rate

    data = load_split(root, "train", build=False, progress=False)
    seen = load_split(root, "seen", build=False, progress=False)
    tr_idx, _ = train_val_split(data, seen, cfg.val_fraction, cfg.seed)
    g = cfg.batch_size * world_size
    total = (len(tr_idx) // g) * cfg.epochs
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(cfg.seed)
        model = build_model(cfg.model_config()).to(memory_format=torch.channels_last)
    opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    model.train()
    losses = []
    threads = torch.get_num_threads()
    torch.set_num_threads(cfg.threads)  # the ranks' thread count: same kernels, same rounding
    try:
        _reference_steps(model, opt, cfg, data, tr_idx, g, total, steps, world_size, losses)
    finally:
        torch.set_num_threads(threads)
    return losses, {k: v.detach() for k, v in model.state_dict().items()}


def _reference_steps(model, opt, cfg, data, tr_idx, g, total, steps, world_size, losses) -> None:
    from ndrql.training.losses import ndr_loss
    from ndrql.training.loop import learning_rate

    for gs, (_, (x, region, guide)) in zip(range(steps), train_batches(data, tr_idx, g, cfg.seed, 0, 0, cfg.augment, cfg.encoding or "point")):
        for group in opt.param_groups:
            group["lr"] = learning_rate(cfg, gs, total)
        parts = [ndr_loss(*model(x[r::world_size].contiguous(memory_format=torch.channels_last)), region[r::world_size], guide[r::world_size])
                 for r in range(world_size)]
        loss = sum(parts) / world_size
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        losses.append(loss.item())


@pytest.mark.slow
def test_ddp_two_processes_match_single_process_and_resume_in_one(synthetic, tmp_path):
    cfg = tiny_config(synthetic, max_steps=3)
    run_dir = tmp_path / "run"
    r0, r1 = run_ddp(cfg, run_dir, tmp_path / "out1")

    # both ranks hold identical weights (parameters and, after the final sync, BatchNorm buffers)
    assert r0["params"].keys() == r1["params"].keys()
    for k in r0["params"]:
        assert torch.equal(r0["params"][k], r1["params"][k]), k
    assert r0["state"]["step"] == r1["state"]["step"] == 3
    assert r0["state"]["world_size"] == 2 and r0["state"]["global_batch"] == 4

    # the loss matches a single-process run on the same global batch
    ddp_losses = [(a + b) / 2 for a, b in zip(r0["losses"], r1["losses"])]
    ref_losses, ref_params = reference_losses(cfg, synthetic, 3, 2)
    np.testing.assert_allclose(ddp_losses, ref_losses, rtol=1e-5)
    assert ddp_losses[0] != pytest.approx(ddp_losses[2], rel=1e-3)  # training moved the weights
    for k, v in ref_params.items():
        if v.is_floating_point() and "running" not in k:
            torch.testing.assert_close(r0["params"][k], v, rtol=1e-3, atol=1e-5, msg=k)

    # the checkpoint is written by rank 0 only, unwrapped, and loads for evaluation / ndrql plan
    assert sorted(p.name for p in run_dir.iterdir()) == ["last.pt"]
    ck = load_checkpoint(run_dir / "last.pt")
    assert not any(k.startswith("module.") for k in ck["model"])
    assert ck["state"]["world_size"] == 2 and ck["state"]["global_step"] == 3
    model = model_from_checkpoint(ck)
    for k, v in model.state_dict().items():
        assert torch.equal(v, r0["params"][k]), k

    # it resumes in a single process with the same global batch (4 = 2 x 2) ...
    from ndrql.training.loop import run_training

    with pytest.raises(CheckpointError, match="global batch of 4.*--batch-size 4"):
        run_training(dataclasses.replace(cfg, max_steps=1), run_dir, resume=True, progress=False, log=lambda m: None)
    logs: list[str] = []
    one = run_training(dataclasses.replace(cfg, batch_size=4, max_steps=2), run_dir, resume=True, progress=False, log=logs.append)
    assert one.state["step"] == 5 and one.state["global_step"] == 5 and one.state["world_size"] == 1
    assert "resumed from" in logs[0] and "2 process(es)" in logs[0]

    # ... and the reverse: that single-process checkpoint resumes under DDP and finishes the epochs
    r0, r1 = run_ddp(dataclasses.replace(cfg, max_steps=0), run_dir, tmp_path / "out2", resume=True)
    for k in r0["params"]:
        assert torch.equal(r0["params"][k], r1["params"][k]), k
    steps_per_epoch = 36 // 4  # 40 samples minus 2 validation maps x 2 samples, global batch 4
    assert r0["state"]["epoch"] == 2 and r0["state"]["global_step"] == 2 * steps_per_epoch
    assert sorted(p.name for p in run_dir.iterdir()) == ["best.pt", "last.pt", "metrics.csv"]
    rows = (run_dir / "metrics.csv").read_text().splitlines()
    assert len(rows) == 3 and rows[0].startswith("epoch,global_step")


# --- the command line (refusals run through main(); torchrun launches the real console script) ---------------

def _rankless_env() -> dict[str, str]:
    """This environment without a launcher's rank variables (a refused flag trains nothing: the command runs in
    the test process unless a launcher set them, see ``helpers.cli``)."""
    return {k: v for k, v in os.environ.items() if k not in ("RANK", "WORLD_SIZE", "LOCAL_RANK")}


def _train_env() -> dict[str, str]:
    """This environment without a launcher's rank variables, with one OpenMP thread."""
    return {**_rankless_env(), "OMP_NUM_THREADS": "1"}


@pytest.mark.parametrize(("flags", "message"), [
    (["--device", "tpu"], "unknown --device 'tpu'; valid: auto, cpu, cuda, mps"),
    (["--amp-dtype", "fp8"], "unknown --amp-dtype 'fp8'; valid: auto, bf16, fp16"),
    (["--exclude-families", "maze,mazes"], "unknown family mazes (known: "),
])
def test_cli_rejects_bad_device_flags_in_one_line(ndrql_exe, synthetic, tmp_path, flags, message):
    r = run_cli(ndrql_exe, "train", "--data", str(synthetic), "--run-dir", str(tmp_path / "run"), *flags,
                env=_rankless_env())
    assert_one_line_error(r, message)
    assert not (tmp_path / "run").exists()


def test_sync_bn_needs_cuda(synthetic, tmp_path):
    from ndrql.training.loop import run_training

    with pytest.raises(D.DeviceError, match="--sync-bn needs CUDA"):
        run_training(tiny_config(synthetic, sync_bn=True), tmp_path / "run", progress=False, log=lambda m: None)


@pytest.mark.skipif(torch.cuda.is_available(), reason="checks the message on a machine without CUDA")
def test_cli_device_cuda_without_gpu_says_so(ndrql_exe, synthetic, tmp_path):
    r = run_cli(ndrql_exe, "train", "--data", str(synthetic), "--run-dir", str(tmp_path / "run"), "--device", "cuda",
                env=_rankless_env())
    assert_one_line_error(r, "no CUDA device is visible")


@pytest.mark.slow
def test_torchrun_two_processes_via_the_cli(synthetic, tmp_path):
    """``torchrun -m ndrql train`` as the docs show it: one run directory, rank 0's lines only."""
    import json
    import sys

    torchrun = Path(sys.executable).with_name("torchrun")
    if not torchrun.exists():
        pytest.skip("torchrun is not installed beside this python")
    run_dir = tmp_path / "run"
    r = run_cli([str(torchrun)], "--standalone", "--nproc-per-node", "2", "-m", "ndrql", "train",
                "--data", str(synthetic), "--run-dir", str(run_dir), "--model", "ndr-stdc1-quarter",
                "--model-overrides", json.dumps(TINY), "--device", "cpu", "--no-bf16", "--batch-size", "2",
                "--epochs", "1", "--val-fraction", "0.1", "--threads", "1", "--no-progress", env=_train_env())
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.count("run directory:") == 1
    assert "DDP: 2 processes (gloo), 2 per process, global batch 4" in r.stdout
    assert r.stdout.count("epoch 1: loss") == 1
    assert sorted(p.name for p in run_dir.iterdir()) == ["best.pt", "last.pt", "metrics.csv"]
    ck = load_checkpoint(run_dir / "last.pt")
    assert ck["state"]["epoch"] == 1 and ck["state"]["global_step"] == 36 // 4 and ck["state"]["world_size"] == 2
