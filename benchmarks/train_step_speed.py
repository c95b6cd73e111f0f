"""Training step speed of the single-process CPU path, before and after the device/DDP work (issue 7).

The training loop before that work is read from git (``--before``, default ``0a2f4ac``, the last
commit before it) and imported beside the current one, so both run in this process, on the same
data, the same batches and the same machine:

1. **same steps**: the old inline step and the current ``train_step`` on the world-of-one path, from
   the same weights on the same batches, must leave bit-identical weights (checked before timing);
2. **step**: CPU time of one optimisation step (forward under bf16 autocast, BCE + Dice, backward,
   AdamW), old inline code vs ``train_step``, alternated in rounds on pre-built batches;
3. **loop** (``--loop-steps N``): the whole ``train()`` of each version for N steps from a fresh run
   directory (data from the cache, split, model build, batches, steps, checkpoint); the figure is the
   loop's own per-step timer (``state['train_seconds']``) and the CPU time of the whole call.

``--resume-check CKPT``: copy a ``last.pt`` written by the old loop into a temporary run directory,
resume it for one step with each version, and check the weights come out bit-identical (the running
job's checkpoints keep resuming exactly). The checkpoint itself is only read.

    .venv/bin/python benchmarks/train_step_speed.py                       # model of the default run
    .venv/bin/python benchmarks/train_step_speed.py --loop-steps 4 --resume-check ~/.cache/ndrql/runs/ndr-default/last.pt

Times are CPU time with one intra-op thread (``torch.set_num_threads(1)``; ``time.thread_time`` for
steps, ``time.process_time`` for whole calls), so a busy machine slows the wall clock, not the figures.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import torch

from ndrql.dataset.batches import train_batches
from ndrql.dataset.cache import load_split
from ndrql.dataset.layout import default_root
from ndrql.model.registry import build_model
from ndrql.training import distributed as D
from ndrql.training import loop as new_loop
from ndrql.training.config import TrainConfig
from ndrql.training.losses import ndr_loss

REPO = Path(__file__).resolve().parents[1]


def load_old_loop(rev: str):
    """``src/ndrql/training/loop.py`` at git revision ``rev``, imported as a module."""
    src = subprocess.run(["git", "-C", str(REPO), "show", f"{rev}:src/ndrql/training/loop.py"], check=True, capture_output=True, text=True).stdout
    path = Path(tempfile.mkdtemp()) / "loop_before.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location("ndrql_loop_before", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def old_step(model, opt, batch, lr, bf16: bool):
    """The step exactly as the loop before issue 7 wrote it inline."""
    x, region, guide = batch
    for group in opt.param_groups:
        group["lr"] = lr
    with torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
        r_logit, g_logit = model(x.contiguous(memory_format=torch.channels_last))
    loss = ndr_loss(r_logit, g_logit, region, guide)
    opt.zero_grad(set_to_none=True)
    loss.backward()
    opt.step()
    return loss


def fresh(cfg: TrainConfig):
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(0)
        model = build_model(cfg.model_config()).to(memory_format=torch.channels_last)
    return model, torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)


def check_same_steps(cfg: TrainConfig, batches, precision) -> None:
    (ma, oa), (mb, ob) = fresh(cfg), fresh(cfg)
    ma.train(), mb.train()
    for i, b in enumerate(batches):
        old_step(ma, oa, b, 1e-3 * (i + 1), cfg.bf16)
        new_loop.train_step(mb, ob, b, 1e-3 * (i + 1), precision)
    for (k, va), vb in zip(ma.state_dict().items(), mb.state_dict().values()):
        if not torch.equal(va, vb):
            sys.exit(f"FAIL: weights differ after {len(batches)} steps (first: {k})")
    print(f"same steps: old inline step and train_step leave bit-identical weights after {len(batches)} steps")


def time_steps(cfg: TrainConfig, batches, precision, rounds: int) -> dict[str, list[float]]:
    """CPU seconds per step, per round, of each variant (alternated; one warm-up step each)."""
    variants = {
        "before (inline step)": lambda m, o, b: old_step(m, o, b, 1e-4, cfg.bf16),
        "after (train_step, world of one)": lambda m, o, b: new_loop.train_step(m, o, b, 1e-4, precision),
    }
    models = {name: fresh(cfg) for name in variants}
    out: dict[str, list[float]] = {name: [] for name in variants}
    for name, fn in variants.items():
        m, o = models[name]
        m.train()
        fn(m, o, batches[0])
    for r in range(rounds):
        order = list(variants) if r % 2 == 0 else list(variants)[::-1]
        for name in order:
            m, o = models[name]
            t0 = time.thread_time()
            for b in batches:
                float(variants[name](m, o, b).detach())  # the loop reads the loss every step
            out[name].append((time.thread_time() - t0) / len(batches))
    return out


def time_loops(cfg: TrainConfig, old_loop, steps: int, repeats: int) -> dict[str, list[tuple[float, float]]]:
    """(loop's per-step seconds, CPU seconds of the whole call) per repeat, old and new train()."""
    out: dict[str, list[tuple[float, float]]] = {"before": [], "after": []}
    c = dataclasses.replace(cfg, max_steps=steps, checkpoint_minutes=1e9)
    for r in range(repeats):
        for name in (["before", "after"] if r % 2 == 0 else ["after", "before"]):
            fn = old_loop.train if name == "before" else new_loop.train
            with tempfile.TemporaryDirectory() as d:
                t0 = time.process_time()
                state = fn(c, Path(d) / "run", progress=False, log=lambda m: None)
                out[name].append((state["train_seconds"] / steps, time.process_time() - t0))
    return out


def resume_check(cfg_cli: TrainConfig, old_loop, ckpt: Path) -> None:
    from ndrql.model.checkpoint import load_checkpoint

    ck = load_checkpoint(ckpt)
    saved = ck["train_config"]
    cfg = dataclasses.replace(TrainConfig(**{k: v for k, v in saved.items() if k in {f.name for f in dataclasses.fields(TrainConfig)}}),
                              data=cfg_cli.data, threads=1, max_steps=1)
    weights = {}
    for name, mod in (("before", old_loop), ("after", new_loop)):
        with tempfile.TemporaryDirectory() as d:
            shutil.copy(ckpt, Path(d) / "last.pt")
            state = mod.train(cfg, d, resume=True, progress=False, log=lambda m: None)
            weights[name] = load_checkpoint(Path(d) / "last.pt")["model"]
    same = all(torch.equal(a, weights["after"][k]) for k, a in weights["before"].items())
    print(f"resume check ({ckpt}, epoch {ck['state']['epoch']} step {ck['state']['step']}): one more step with each version -> "
          f"step {state['step']}, weights {'bit-identical' if same else 'DIFFERENT'}")
    if not same:
        sys.exit(1)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", default="0a2f4ac", help="git revision of the loop before issue 7")
    ap.add_argument("--model", default=TrainConfig.model)
    ap.add_argument("--batch-size", type=int, default=TrainConfig.batch_size)
    ap.add_argument("--steps", type=int, default=3, help="steps per timed round")
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--loop-steps", type=int, default=0, help="also time whole train() calls of N steps (0 = skip)")
    ap.add_argument("--resume-check", type=Path, default=None, metavar="CKPT")
    ap.add_argument("--no-bf16", dest="bf16", action="store_false")
    args = ap.parse_args()

    torch.set_num_threads(1)
    root = default_root()
    if root is None:
        sys.exit("the dataset is not beside the repository (../shared/data/path-planning-dataset)")
    cfg = TrainConfig(data=str(root), model=args.model, batch_size=args.batch_size, bf16=args.bf16, threads=1, device="cpu")
    old_loop = load_old_loop(args.before)
    print(f"{platform.processor() or platform.machine()}, torch {torch.__version__}, 1 thread; model {cfg.model}, "
          f"batch {cfg.batch_size}, bf16 {cfg.bf16}; before = loop.py at {args.before}")
    if args.resume_check:
        resume_check(cfg, old_loop, args.resume_check)

    data = load_split(cfg.data, "train", progress=False)
    encoding = cfg.model_config().get("encoding", "point")
    batches = [b for _, b in zip(range(args.steps), (b for _, b in train_batches(data, torch.arange(len(data)).numpy(), cfg.batch_size, 0, 0, 0, True, encoding)))]
    precision = D.precision_for(torch.device("cpu"), cfg.bf16)
    check_same_steps(cfg, batches[:2], precision)
    res = time_steps(cfg, batches, precision, args.rounds)
    print(f"step ({args.rounds} rounds x {args.steps} steps, CPU s/step: median [min..max]):")
    for name, v in res.items():
        print(f"  {name:34s} {statistics.median(v):.3f} [{min(v):.3f}..{max(v):.3f}]  = {cfg.batch_size / statistics.median(v):.2f} samples/s per core")
    names = list(res)
    print(f"  after/before: {statistics.median(res[names[1]]) / statistics.median(res[names[0]]):.3f}")
    if args.loop_steps:
        lr = time_loops(cfg, old_loop, args.loop_steps, 2)
        print(f"loop (train() for {args.loop_steps} steps, 2 repeats each): loop's s/step | CPU s of the whole call")
        for name, v in lr.items():
            print(f"  {name:8s} " + "  ".join(f"{a:.3f} | {b:.1f}" for a, b in v))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
