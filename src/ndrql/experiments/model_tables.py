"""Tables 1 and 4: F1 of the NDR model (and the RGP-style peer; and the Table 4 variants).

Both call the lead's evaluation (:func:`ndrql.training.evaluate.evaluate`, SPEC 5: threshold 0.5,
per-image pixel F1, mean over the split) on TEST/SEEN and TEST/UNSEEN. Table 4 trains every
variant (input encoding x guideline decoder) with the same optimiser-step budget through
:func:`ndrql.training.loop.train`, each in its own run directory (resumable), then evaluates them.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Callable

from ndrql.errors import NdrqlError
from ndrql.experiments.report import machine, machine_line, md_table

#: Paper Table 1 (reference only; their numbers, their models, their GPU training).
PAPER_TABLE1 = {"RGP": (92.81, 58.16, 59.74, 35.82), "NEED": (92.34, None, 59.16, None),
                "MPT": (87.70, None, 49.75, None), "NDR": (93.02, 61.22, 71.96, 37.31)}


@dataclass(frozen=True)
class ModelVariant:
    """A row of Table 4."""

    name: str
    encoding: str
    """Input encoding (ndrql.dataset.encodings)."""
    guideline_decoder: bool
    paper: tuple[float, float, float, float]
    """Paper's seen R, seen G, unseen R, unseen G."""

    @property
    def model(self) -> str:
        return "ndr-stdc1-half" if self.guideline_decoder else "ndr-stdc1-half-noguide"


TABLE4_VARIANTS = (
    ModelVariant("rgb", "rgb", False, (91.70, 58.25, 69.81, 35.39)),
    ModelVariant("gauss25", "gauss25", False, (88.91, 55.34, 67.87, 33.71)),
    ModelVariant("gauss50", "gauss50", False, (91.19, 57.02, 69.98, 37.65)),
    ModelVariant("distance", "distance", False, (84.46, 53.67, 65.16, 33.04)),
    ModelVariant("point", "point", False, (92.63, 59.12, 70.02, 35.33)),
    ModelVariant("point+GD", "point", True, (93.02, 61.22, 71.96, 37.31)),
)


def _fmt(x: float | None) -> str:
    return "-" if x is None or x != x else f"{x:.2f}"


def evaluate_weights(path: str | Path, root: Path, limit: int | None, progress: bool) -> dict[str, dict[str, float]]:
    """Mean F1 (percent) on seen and unseen for a checkpoint (the lead's :func:`evaluate`)."""
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
    return out


def table1(out_dir: str | Path, data: str | None = None, weights: str | None = None, rgp_weights: str | None = None,
           limit: int | None = None, progress: bool = True, command: str = "", log: Callable[[str], None] = print) -> Path:
    """Region/guideline F1 of NDR and the RGP-style peer on seen and unseen, paper values beside."""
    from ndrql.experiments.problems import resolve_root
    from ndrql.model.predict import default_weights_path

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    root = resolve_root(data)
    ndr = Path(weights) if weights else default_weights_path()
    rgp = Path(rgp_weights or os.environ.get("NDRQL_RGP_WEIGHTS", Path.home() / ".cache/ndrql/runs/rgp/last.pt"))
    missing = [f"{n} weights {p}" for n, p in (("NDR", ndr), ("RGP", rgp)) if not Path(p).is_file()]
    if not Path(ndr).is_file():
        raise NdrqlError(f"table1 needs the NDR weights ({ndr}); set NDRQL_WEIGHTS or pass --weights")
    rows, numbers = [], {}
    for name, path in (("NDR", ndr), ("RGP", rgp)):
        if not Path(path).is_file():
            rows.append([f"{name} (ours)", "needs weights", "", "", "", "", str(path)])
            continue
        r = evaluate_weights(path, root, limit, progress)
        numbers[name] = r
        rows.append([f"{name} (ours)", _fmt(r["seen"]["region_f1"]), _fmt(r["seen"]["guideline_f1"]),
                     _fmt(r["unseen"]["region_f1"]), _fmt(r["unseen"]["guideline_f1"]),
                     _fmt(r["unseen"]["region_f1_original"]), str(path)])
    for name, v in PAPER_TABLE1.items():
        rows.append([f"{name} (paper, reference)"] + [_fmt(x) for x in v] + ["-", "paper Table 1"])
    md = ["# table1: region / guideline F1 (%) on TEST/SEEN and TEST/UNSEEN", "", f"Command: `{command}`", "",
          f"Machine: {machine_line(machine())}.", "",
          f"Samples per split: {limit or 'all (1,200)'}; F1 per SPEC 5 via ndrql.training.evaluate.", "",
          md_table(["model", "seen R", "seen G", "unseen R", "unseen G", "unseen R (original labels)", "weights"], rows),
          "", "unseen R uses the 300 NARROW PASSAGE region labels regenerated from the guideline (the upstream ones "
          "are broken); 'original labels' scores the same predictions against the upstream labels resized to 201 px, "
          "as the paper presumably did."]
    if missing:
        md += ["", "Missing: " + "; ".join(missing) + " (RGP: set NDRQL_RGP_WEIGHTS or train `--model rgp`)."]
    path = out_dir / "table1.md"
    path.write_text("\n".join(md) + "\n")
    (out_dir / "summary.json").write_text(json.dumps(numbers, indent=1))
    return path


def train_variant(v: ModelVariant, run_dir: Path, data: str, budget: int, log: Callable[[str], None]) -> Path:
    """Train one Table 4 variant for ``budget`` optimiser steps (resumes a killed run)."""
    from ndrql.training.config import TrainConfig
    from ndrql.training.loop import train

    cfg = TrainConfig(data=data, model=v.model, encoding=v.encoding, max_steps=budget, threads=1)
    train(cfg, run_dir, resume=(run_dir / "last.pt").is_file(), progress=True, log=log)
    return run_dir / "last.pt"


def table4(out_dir: str | Path, data: str | None = None, budget: int | None = None, run: bool = False,
           limit: int | None = None, progress: bool = True, command: str = "", log: Callable[[str], None] = print) -> Path:
    """Table 4: every variant trained with the same budget, evaluated on seen/unseen.

    Without ``run``, variants not trained yet are listed with the command that trains them; the
    ones already trained (``<out>/runs/<variant>/last.pt``) are evaluated.
    """
    from ndrql.experiments.problems import resolve_root
    from ndrql.training.config import TrainConfig

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    root = resolve_root(data)
    budget = int(budget) if budget else 0
    if run and budget <= 0:
        raise NdrqlError("table4 --run needs --budget STEPS (the same optimiser-step budget for every variant)")
    rows, todo = [], []
    for v in TABLE4_VARIANTS:
        run_dir = out_dir / "runs" / v.name
        ck = run_dir / "last.pt"
        if run:
            train_variant(v, run_dir, str(root), budget, log)
        if ck.is_file():
            r = evaluate_weights(ck, root, limit, progress)
            ours = [_fmt(r["seen"]["region_f1"]), _fmt(r["seen"]["guideline_f1"]), _fmt(r["unseen"]["region_f1"]),
                    _fmt(r["unseen"]["guideline_f1"])]
        else:
            ours = ["not trained"] + [""] * 3
            todo.append(v.name)
        rows.append([v.name, "yes" if v.guideline_decoder else "no"] + ours + [" / ".join(_fmt(x) for x in v.paper)])
    cfg = TrainConfig()
    md = ["# table4: input encoding and guideline decoder ablation (F1 %)", "", f"Command: `{command}`", "",
          f"Machine: {machine_line(machine())}.", "",
          f"Every variant: preset ndr-stdc1-half (-noguide without GD), TrainConfig defaults "
          f"(batch {cfg.batch_size}, lr {cfg.lr}, {cfg.epochs}-epoch cosine schedule) stopped after "
          f"{budget or '?'} optimiser steps (`max_steps`), seed {cfg.seed}; evaluated on {limit or 'all'} samples per split.",
          "", md_table(["encoding", "GD", "seen R", "seen G", "unseen R", "unseen G", "paper (sR / sG / uR / uG)"], rows,
                       ["l", "l", "r", "r", "r", "r", "r"])]
    if todo:
        md += ["", f"Not trained yet: {', '.join(todo)}. Train them all with the same budget (resumable; "
               "about the cost of one model training per variant):", "",
               f"    nice -n 10 ndrql reproduce table4 --run --budget {budget or 'STEPS'}"]
        log(f"table4: {len(todo)} variants not trained; run `ndrql reproduce table4 --run --budget STEPS`")
    path = out_dir / "table4.md"
    path.write_text("\n".join(md) + "\n")
    return path
