"""Tables 1 and 4 and the model-sizing comparison: F1 of trained NDR models (and the RGP-style peer).

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
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from ndrql.errors import NdrqlError
from ndrql.experiments.paper import paper_table
from ndrql.experiments.report import machine, machine_line, md_table

UNSEEN_NOTE = ("unseen R scores the 300 NARROW PASSAGE samples against region labels regenerated from the guideline "
               "(the upstream ones are broken: docs/dataset.md); 'original labels' scores the same predictions "
               "against the upstream labels resized to 201 px, as the paper presumably did.")


@dataclass(frozen=True)
class ModelVariant:
    """A row of Table 4."""

    name: str
    encoding: str
    """Input encoding (ndrql.dataset.encodings)."""
    guideline_decoder: bool

    @property
    def model(self) -> str:
        return "ndr-stdc1-half" if self.guideline_decoder else "ndr-stdc1-half-noguide"


TABLE4_VARIANTS = (
    ModelVariant("rgb", "rgb", False),
    ModelVariant("gauss25", "gauss25", False),
    ModelVariant("gauss50", "gauss50", False),
    ModelVariant("distance", "distance", False),
    ModelVariant("point", "point", False),
    ModelVariant("point+GD", "point", True),
)

#: The sizing comparison (docs/model.md): run directory under the runs root -> what it varies.
SIZING_RUNS = (
    ("width/quarter", "quarter width (0.25), bf16"),
    ("table4/point+GD", "half width (0.5, the default), bf16"),
    ("width/full", "full width (1.0), bf16"),
    ("precision/half-fp32", "half width (0.5), fp32"),
)


def runs_root() -> Path:
    """``$NDRQL_CACHE/runs``: where ``ndrql train`` keeps run directories by default."""
    from ndrql.dataset.cache import cache_dir

    return cache_dir() / "runs"


def _fmt(x: float | None, digits: int = 2) -> str:
    return "-" if x is None or x != x else f"{x:.{digits}f}"


def run_status(run_dir: Path) -> dict[str, Any] | None:
    """Where a run directory stands: its schedule, progress, time and best validation F1 (None if empty)."""
    from ndrql.training.checkpoint import load_checkpoint

    last = run_dir / "last.pt"
    if not last.is_file():
        return None
    ck = load_checkpoint(last)
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
    from ndrql.training.checkpoint import load_checkpoint

    ck = load_checkpoint(path)
    st, tc = ck.get("state", {}), ck.get("train_config", {})
    params = sum(v.numel() for k, v in ck["model"].items() if "running_" not in k and "num_batches" not in k)
    return {"params_m": params / 1e6, "epochs": int(st.get("epoch", tc.get("epochs", 0))),
            "steps": int(st.get("global_step", 0)), "train_hours": float(st.get("train_seconds", 0.0)) / 3600}


def evaluate_weights(path: str | Path, root: Path, limit: int | None, progress: bool,
                     cache: Path | None = None) -> dict[str, dict[str, float]]:
    """Mean F1 (percent) on seen and unseen for a checkpoint, cached in ``cache`` by file digest."""
    from ndrql.io import file_digest, write_json

    key = f"{file_digest(path)[:16]}-{limit or 'all'}"
    cached = cache / f"{key}.json" if cache is not None else None
    if cached is not None and cached.is_file():
        try:
            return json.loads(cached.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError):
            pass  # a damaged cache entry is recomputed
    import numpy as np
    import torch

    from ndrql.dataset.cache import load_split
    from ndrql.training.checkpoint import load_checkpoint, model_from_checkpoint
    from ndrql.training.evaluate import evaluate

    torch.set_num_threads(max(1, int(os.environ.get("NDRQL_EVAL_THREADS", "1"))))
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


def _f1_cells(r: dict[str, dict[str, float]]) -> list[str]:
    return [_fmt(r["seen"]["region_f1"]), _fmt(r["seen"]["guideline_f1"]), _fmt(r["unseen"]["region_f1"]),
            _fmt(r["unseen"]["guideline_f1"]), _fmt(r["unseen"]["region_f1_original"])]


def _write(out_dir: Path, name: str, lines: list[str], numbers: dict) -> Path:
    from ndrql.io import write_json, write_text

    path = write_text(out_dir / f"{name}.md", "\n".join(lines) + "\n")
    write_json(out_dir / "summary.json", numbers, indent=None, strict=False)
    return path


def _header(title: str, command: str, limit: int | None) -> list[str]:
    return [f"# {title}", "", f"Command: `{command}`", "", f"Machine: {machine_line(machine())}.", "",
            f"Samples per split: {limit or 'all (1,200)'}; F1 per docs/method.md via ndrql.training.evaluate.", ""]


def default_rgp_weights() -> Path:
    """The RGP peer's weights: ``$NDRQL_RGP_WEIGHTS``, else the best (or last) checkpoint of ``runs/rgp``."""
    if os.environ.get("NDRQL_RGP_WEIGHTS"):
        return Path(os.environ["NDRQL_RGP_WEIGHTS"])
    run = runs_root() / "rgp"
    return run / "best.pt" if (run / "best.pt").is_file() else run / "last.pt"


def table1(out_dir: str | Path, data: str | None = None, weights: str | None = None, rgp_weights: str | None = None,
           limit: int | None = None, progress: bool = True, command: str = "", log: Callable[[str], None] = print) -> Path:
    """Region/guideline F1 of NDR and the RGP-style peer on seen and unseen, with their training budgets."""
    from ndrql.experiments.problems import resolve_root
    from ndrql.model.weights import PAPER_WEIGHTS, resolve_weights

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    root = resolve_root(data)
    ndr = resolve_weights(weights or None, PAPER_WEIGHTS)
    rgp = Path(rgp_weights) if rgp_weights else default_rgp_weights()
    if not ndr.is_file():
        raise NdrqlError(f"table1 needs the NDR weights ({ndr}); set NDRQL_WEIGHTS or pass --weights")
    rows, numbers, missing = [], {}, []
    for name, path in (("NDR", ndr), ("RGP", rgp)):
        if not path.is_file():
            missing.append(name)
            rows.append([f"{name} (ours)", "needs weights"] + [""] * 7 + [str(path)])
            continue
        r = evaluate_weights(path, root, limit, progress, cache=out_dir / "evals")
        s = checkpoint_summary(path)
        numbers[name] = {**r, "training": s, "weights": str(path)}
        rows.append([f"{name} (ours)"] + _f1_cells(r) + [_fmt(s["params_m"]), s["epochs"], _fmt(s["train_hours"]), str(path)])
    for name, v in paper_table("table1")["rows"].items():  # reference only: their models, their GPU training
        rows.append([f"{name} (paper, reference)"] + [_fmt(x) for x in v] + ["-", "-", "-", "-", "paper Table 1"])
    md = _header("table1: region / guideline F1 (%) on TEST/SEEN and TEST/UNSEEN", command, limit)
    md += [md_table(["model", "seen R", "seen G", "unseen R", "unseen G", "unseen R (original labels)", "params (M)",
                     "epochs", "train h (CPU)", "weights"], rows), "",
           "Both of ours: the same pipeline (ndrql train: data, split, augmentation, BCE + Dice, AdamW, cosine "
           "schedule, batch 16, bf16, seed 0) and the same number of epochs; 'train h' is optimiser time on this "
           "machine's CPU as recorded in the checkpoint.", "", UNSEEN_NOTE]
    if missing:
        md += ["", f"Missing: {', '.join(missing)} weights. Train the RGP peer with "
               "`ndrql train --model rgp --epochs 7 --run-dir ~/.cache/ndrql/runs/rgp` (or set NDRQL_RGP_WEIGHTS)."]
        log(f"table1: no weights for {', '.join(missing)}")
    return _write(out_dir, "table1", md, numbers)


def variant_config(v: ModelVariant, data: str, epochs: int, threads: int, base=None):
    """The TrainConfig of a Table 4 variant: ``base`` (default: the default pipeline) with the variant's
    model and encoding and a complete ``epochs``-long schedule."""
    from dataclasses import replace

    from ndrql.training.config import TrainConfig

    return replace(base or TrainConfig(), data=data, model=v.model, encoding=v.encoding, epochs=epochs, threads=threads)


def _train_one(cfg, run_dir: str, queue=None) -> str:
    """Process-pool entry point: train (or resume) one run quietly, its log beside its checkpoints.

    Every log line also goes to ``queue`` (when given) as ``(run_dir, line)`` for the parent's progress bar.
    """
    from ndrql.training.loop import train

    run = Path(run_dir)
    run.mkdir(parents=True, exist_ok=True)
    with open(run / "train.log", "a") as fh:
        def log(msg: str) -> None:
            print(msg, file=fh, flush=True)
            if queue is not None:
                queue.put((run_dir, msg))

        train(cfg, run, resume=(run / "last.pt").is_file(), progress=False, log=log)
    return run_dir


def _steps_done(line: str) -> tuple[int, int, int] | None:
    """``(epoch, step, steps per epoch)`` from a training log line ``epoch E step S/N ...``."""
    import re

    m = re.match(r"epoch (\d+) step (\d+)/(\d+)", line)
    return (int(m[1]), int(m[2]), int(m[3])) if m else None


def train_variants(variants: list[ModelVariant], runs: Path, data: str, epochs: int, workers: int,
                   log: Callable[[str], None], base=None, progress: bool = True) -> None:
    """Train the variants not finished yet, ``workers`` at a time (one process each, cores shared evenly),
    with one progress bar over all their optimiser steps (ETA included)."""
    import queue as queue_mod
    import sys
    from concurrent.futures import FIRST_COMPLETED, wait

    from tqdm import tqdm

    from ndrql.workers import process_pool, start_manager

    threads = max(1, (os.cpu_count() or 1) // workers)
    todo = []
    for v in variants:
        st = run_status(runs / v.name)
        if st is not None and st["epochs"] != epochs:
            raise NdrqlError(f"{runs / v.name} was trained with a {st['epochs']}-epoch schedule; use --epochs {st['epochs']} "
                             f"or another --runs directory (every variant needs the same budget)")
        if st is None or not st["finished"]:
            todo.append(v)
    if not todo:
        return
    log(f"table4: training {len(todo)} variant(s) for {epochs} epochs, {workers} at a time, {threads} thread(s) each "
        f"(logs: {runs}/<variant>/train.log)")
    # spawn: each training process starts clean; it and the queue's manager die with this process
    with start_manager("spawn") as manager, process_pool(workers, start_method="spawn") as pool:
        q = manager.Queue()
        futures = {pool.submit(_train_one, variant_config(v, data, epochs, threads, base), str(runs / v.name), q): v
                   for v in todo}
        done_steps: dict[str, int] = {}
        bar = tqdm(total=None, desc="table4 training", unit="step", disable=not progress, file=sys.stderr)
        pending = set(futures)
        while pending:
            finished, pending = wait(pending, timeout=2.0, return_when=FIRST_COMPLETED)
            while True:
                try:
                    run_dir, line = q.get_nowait()
                except queue_mod.Empty:
                    break
                pos = _steps_done(line)
                if pos is None:
                    continue
                epoch, step, per_epoch = pos
                if bar.total is None:
                    bar.total = len(todo) * epochs * per_epoch
                done_steps[run_dir] = (epoch - 1) * per_epoch + step
                bar.n = sum(done_steps.values())
                bar.refresh()
            for fut in finished:
                fut.result()
                log(f"table4: {futures[fut].name} trained")
        bar.close()


def table4(out_dir: str | Path, data: str | None = None, epochs: int = 2, run: bool = False, runs: str | Path | None = None,
           workers: int = 2, limit: int | None = None, progress: bool = True, command: str = "",
           log: Callable[[str], None] = print, base=None) -> Path:
    """Table 4: every variant trained with the same budget (a complete ``epochs``-long schedule), evaluated on seen/unseen.

    Variants train in ``<runs>/table4/<variant>`` (``runs`` defaults to :func:`runs_root`). Without
    ``run``, the variants already trained there are evaluated and the others
    listed with the command that trains them; an unfinished run is shown with its progress, never scored.
    ``base`` (a TrainConfig) changes the pipeline for every variant alike (tests use tiny settings).
    """
    from ndrql.experiments.problems import resolve_root

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    root = resolve_root(data)
    runs = (Path(runs) if runs else runs_root()) / "table4"
    if epochs < 1:
        raise NdrqlError(f"table4 --epochs must be >= 1, got {epochs}")
    if run:
        train_variants(list(TABLE4_VARIANTS), runs, str(root), epochs, workers, log, base, progress)
    rows, todo, numbers = [], [], {}
    paper_rows = paper_table("table4")["rows"]
    for v in TABLE4_VARIANTS:
        st = run_status(runs / v.name)
        head = [v.name, "yes" if v.guideline_decoder else "no"]
        paper = " / ".join(_fmt(x) for x in paper_rows[v.name])
        if st is None or not st["finished"]:
            where = "not trained (no checkpoint yet)" if st is None else f"training: epoch {st['epoch'] + 1}/{st['epochs']}, step {st['step']}"
            rows.append(head + [where] + [""] * 5 + [paper])
            todo.append(v.name)
            continue
        if st["epochs"] != epochs:
            rows.append(head + [f"trained for {st['epochs']} epochs, not {epochs}"] + [""] * 5 + [paper])
            todo.append(v.name)
            continue
        r = evaluate_weights(st["weights"], root, limit, progress, cache=out_dir / "evals")
        numbers[v.name] = {**r, "epochs": st["epochs"], "steps": st["global_step"], "train_hours": st["train_hours"]}
        rows.append(head + _f1_cells(r) + [_fmt(st["train_hours"]), paper])
    md = _header("table4: input encoding and guideline decoder ablation (F1 %)", command, limit)
    md += [f"Every variant: preset ndr-stdc1-half (ndr-stdc1-half-noguide without GD), the default pipeline of "
           f"`ndrql train` (batch 16, AdamW, peak lr 2e-3, bf16, seed 0) with a complete {epochs}-epoch cosine schedule, "
           f"the checkpoint with the best validation F1. Run directories: `{runs}`.", "",
           md_table(["encoding", "GD", "seen R", "seen G", "unseen R", "unseen G", "unseen R (original labels)",
                     "train h (CPU)", "paper (sR / sG / uR / uG)"], rows, ["l", "l"] + ["r"] * 7), "", UNSEEN_NOTE]
    if todo:
        md += ["", f"Not trained yet: {', '.join(todo)}. Train them all with the same budget (resumable):", "",
               f"    ndrql reproduce table4 --run --epochs {epochs}"]
        log(f"table4: {len(todo)} variant(s) not trained; run `ndrql reproduce table4 --run --epochs {epochs}`")
    return _write(out_dir, "table4", md, numbers)


def read_metrics(run_dir: Path) -> list[dict[str, float]]:
    """The per-epoch rows of a run's ``metrics.csv`` (empty when there is none)."""
    path = run_dir / "metrics.csv"
    if not path.is_file():
        return []
    with path.open() as fh:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(fh)]


def sizing(out_dir: str | Path, runs: str | Path | None = None, command: str = "", data: str | None = None,
           limit: int | None = None, progress: bool = True, log: Callable[[str], None] = print) -> Path:
    """Validation F1 against training hours for the model sizes and precisions of :data:`SIZING_RUNS`,
    and each run's best checkpoint scored on TEST/SEEN and TEST/UNSEEN."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ndrql.experiments.problems import resolve_root
    from ndrql.experiments.report import save_figure
    from ndrql.viz.curves import plot_validation_curve

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    root = resolve_root(data)
    runs = Path(runs) if runs else runs_root()
    rows, numbers = [], {}
    fig, (ax_r, ax_g) = plt.subplots(1, 2, figsize=(10, 3.8))
    for name, label in SIZING_RUNS:
        metrics, st = read_metrics(runs / name), run_status(runs / name)
        if not metrics or st is None:
            rows.append([label, "not trained"] + [""] * 7 + [f"`{name}`"])
            continue
        params = checkpoint_summary(st["weights"])["params_m"]
        last = metrics[-1]
        sec_per_step = 3600 * last["train_hours"] / max(1.0, last["global_step"])
        test = evaluate_weights(st["weights"], root, limit, progress, cache=out_dir / "evals")
        numbers[name] = {"label": label, "params_m": params, "s_per_step": sec_per_step, "epochs": metrics, "test": test}
        for ax, key in ((ax_r, "val_region_f1"), (ax_g, "val_guideline_f1")):
            plot_validation_curve(ax, [m["train_hours"] for m in metrics], [m[key] for m in metrics], label=label)
        rows.append([label, _fmt(params), _fmt(sec_per_step), f"{int(last['epoch'])}/{st['epochs']}", _fmt(last["train_hours"]),
                     _fmt(last["val_region_f1"]), _fmt(last["val_guideline_f1"]),
                     f"{_fmt(test['seen']['region_f1'])} / {_fmt(test['seen']['guideline_f1'])}",
                     f"{_fmt(test['unseen']['region_f1'])} / {_fmt(test['unseen']['guideline_f1'])}", f"`{name}`"])
    ax_r.set(xlabel="training hours (one CPU thread)", ylabel="validation region F1 (%)")
    ax_g.set(xlabel="training hours (one CPU thread)", ylabel="validation guideline F1 (%)")
    ax_r.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, out_dir / "sizing.png")
    plt.close(fig)
    md = ["# sizing: validation F1 per training hour, by model width and precision", "", f"Command: `{command}`", "",
          f"Machine: {machine_line(machine())}.", "",
          "Each run: `ndrql train --threads 1` with the same data order, augmentation and schedule length "
          "(tools/train_comparisons.sh); every width with the same 8-channel guideline UNet, so only the backbone "
          "width changes. Validation: 462 samples of held-out TRAIN maps (no SEEN map). Figure: sizing.png.", "",
          md_table(["run", "params (M)", "s/step", "epochs", "train h", "val R", "val G", "seen R / G", "unseen R / G",
                    "run dir"], rows), "", "val: last epoch; seen/unseen: the run's best checkpoint on the full test "
          "sets (unseen with the regenerated NARROW PASSAGE labels)."]
    return _write(out_dir, "sizing", md, numbers)
