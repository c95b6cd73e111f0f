"""Table 4 of the paper: the input encodings and the guideline decoder, each trained with one budget.

Every variant is the same pipeline (``ndrql train``) with its own encoding, with or without the
guideline decoder, trained for a complete ``epochs``-long schedule in ``<runs>/table4/<variant>``
(:func:`train_variants`, resumable) and scored like Table 1 (:mod:`ndrql.experiments.model_runs`).
"""

from __future__ import annotations

import os
import queue as queue_mod
import re
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable

from tqdm import tqdm

from ndrql.errors import NdrqlError
from ndrql.io import open_log
from ndrql.experiments.model_runs import evaluate_weights, run_status, runs_root
from ndrql.experiments.paper import paper_table
from ndrql.dataset.layout import resolve_root
from ndrql.experiments.report import UNSEEN_NOTE, f1_cells, f1_header, fmt_f1, md_table, write_table
from ndrql.training.config import TrainConfig
from ndrql.training.loop import train
from ndrql.workers import run_calls, start_manager


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


def variant_config(v: ModelVariant, data: str, epochs: int, threads: int, base: TrainConfig | None = None) -> TrainConfig:
    """The TrainConfig of a Table 4 variant: ``base`` (default: the default pipeline) with the variant's
    model and encoding and a complete ``epochs``-long schedule."""
    return replace(base or TrainConfig(), data=data, model=v.model, encoding=v.encoding, epochs=epochs, threads=threads)


def _train_one(cfg: TrainConfig, run_dir: str, queue=None) -> str:
    """Process-pool entry point: train (or resume) one run quietly, its log beside its checkpoints.

    Every log line also goes to ``queue`` (when given) as ``(run_dir, line)`` for the parent's progress bar.
    """
    run = Path(run_dir)
    with open_log(run / "train.log") as fh:
        def log(msg: str) -> None:
            print(msg, file=fh, flush=True)
            if queue is not None:
                queue.put((run_dir, msg))

        train(cfg, run, resume=(run / "last.pt").is_file(), progress=False, log=log)
    return run_dir


def _steps_done(line: str) -> tuple[int, int, int] | None:
    """``(epoch, step, steps per epoch)`` from a training log line ``epoch E step S/N ...``."""
    m = re.match(r"epoch (\d+) step (\d+)/(\d+)", line)
    return (int(m[1]), int(m[2]), int(m[3])) if m else None


def train_variants(variants: list[ModelVariant], runs: Path, data: str, epochs: int, workers: int,
                   log: Callable[[str], None], base: TrainConfig | None = None, progress: bool = True) -> None:
    """Train the variants not finished yet, ``workers`` at a time (one process each, cores shared evenly),
    with one progress bar over all their optimiser steps (ETA included)."""
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
    done_steps: dict[str, int] = {}
    bar = tqdm(total=None, desc="table4 training", unit="step", disable=not progress, file=sys.stderr)

    def show_progress(q: Any) -> None:
        """Move the bar by the ``epoch E step S/N`` lines the training processes put on ``q``."""
        while True:
            try:
                run_dir, line = q.get_nowait()
            except queue_mod.Empty:
                return
            pos = _steps_done(line)
            if pos is None:
                continue
            epoch, step, per_epoch = pos
            if bar.total is None:
                bar.total = len(todo) * epochs * per_epoch
            done_steps[run_dir] = (epoch - 1) * per_epoch + step
            bar.n = sum(done_steps.values())
            bar.refresh()

    # spawn: each training process starts clean; it and the queue's manager die with this process
    with start_manager("spawn") as manager:
        q = manager.Queue()
        run_calls(_train_one, [(variant_config(v, data, epochs, threads, base), str(runs / v.name), q) for v in todo],
                  executor="process", workers=workers, start_method="spawn",
                  on_result=lambda i, _: log(f"table4: {todo[i].name} trained"), poll=lambda: show_progress(q))
        bar.close()


def table4(out_dir: str | Path, data: str | None = None, epochs: int = 2, run: bool = False, runs: str | Path | None = None,
           workers: int = 2, limit: int | None = None, progress: bool = True, command: str = "",
           log: Callable[[str], None] = print, base: TrainConfig | None = None) -> Path:
    """Table 4: every variant trained with the same budget (a complete ``epochs``-long schedule), evaluated on seen/unseen.

    Variants train in ``<runs>/table4/<variant>`` (``runs`` defaults to :func:`runs_root`). Without
    ``run``, the variants already trained there are evaluated and the others
    listed with the command that trains them; an unfinished run is shown with its progress, never scored.
    ``base`` (a TrainConfig) changes the pipeline for every variant alike (tests use tiny settings).
    """
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
        paper = " / ".join(fmt_f1(x) for x in paper_rows[v.name])
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
        rows.append(head + f1_cells(r) + [fmt_f1(st["train_hours"]), paper])
    md = f1_header("table4: input encoding and guideline decoder ablation (F1 %)", command, limit)
    md += [f"Every variant: preset ndr-stdc1-half (ndr-stdc1-half-noguide without GD), the default pipeline of "
           f"`ndrql train` (batch 16, AdamW, peak lr 2e-3, bf16, seed 0) with a complete {epochs}-epoch cosine schedule, "
           f"the checkpoint with the best validation F1. Run directories: `{runs}`.", "",
           md_table(["encoding", "GD", "seen R", "seen G", "unseen R", "unseen G", "unseen R (original labels)",
                     "train h (CPU)", "paper (sR / sG / uR / uG)"], rows, ["l", "l"] + ["r"] * 7), "", UNSEEN_NOTE]
    if todo:
        md += ["", f"Not trained yet: {', '.join(todo)}. Train them all with the same budget (resumable):", "",
               f"    ndrql reproduce table4 --run --epochs {epochs}"]
        log(f"table4: {len(todo)} variant(s) not trained; run `ndrql reproduce table4 --run --epochs {epochs}`")
    return write_table(out_dir, "table4", md, numbers)
