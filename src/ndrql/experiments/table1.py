"""Table 1 of the paper: region / guideline F1 of the NDR model and the RGP-style peer.

Both of ours are trained by the same pipeline with the same budget and scored by the same
evaluation (:mod:`ndrql.experiments.model_runs`); the paper's numbers (their models, their GPU
training) are listed below them for reference.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable

from ndrql.errors import NdrqlError
from ndrql.experiments.model_runs import checkpoint_summary, evaluate_weights, runs_root
from ndrql.experiments.paper import paper_table
from ndrql.dataset.layout import resolve_root
from ndrql.experiments.report import UNSEEN_NOTE, f1_cells, f1_header, fmt_f1, md_table, write_table
from ndrql.model.weights import PAPER_WEIGHTS, resolve_weights


def default_rgp_weights() -> Path:
    """The RGP peer's weights: ``$NDRQL_RGP_WEIGHTS``, else the best (or last) checkpoint of ``runs/rgp``."""
    if os.environ.get("NDRQL_RGP_WEIGHTS"):
        return Path(os.environ["NDRQL_RGP_WEIGHTS"])
    run = runs_root() / "rgp"
    return run / "best.pt" if (run / "best.pt").is_file() else run / "last.pt"


def table1(out_dir: str | Path, data: str | None = None, weights: str | None = None, rgp_weights: str | None = None,
           limit: int | None = None, progress: bool = True, command: str = "", log: Callable[[str], None] = print) -> Path:
    """Region/guideline F1 of NDR and the RGP-style peer on seen and unseen, with their training budgets."""
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
        rows.append([f"{name} (ours)"] + f1_cells(r) + [fmt_f1(s["params_m"]), s["epochs"], fmt_f1(s["train_hours"]), str(path)])
    for name, v in paper_table("table1")["rows"].items():  # reference only: their models, their GPU training
        rows.append([f"{name} (paper, reference)"] + [fmt_f1(x) for x in v] + ["-", "-", "-", "-", "paper Table 1"])
    md = f1_header("table1: region / guideline F1 (%) on TEST/SEEN and TEST/UNSEEN", command, limit)
    md += [md_table(["model", "seen R", "seen G", "unseen R", "unseen G", "unseen R (original labels)", "params (M)",
                     "epochs", "train h (CPU)", "weights"], rows), "",
           "Both of ours: the same pipeline (ndrql train: data, split, augmentation, BCE + Dice, AdamW, cosine "
           "schedule, batch 16, bf16, seed 0) and the same number of epochs; 'train h' is optimiser time on this "
           "machine's CPU as recorded in the checkpoint.", "", UNSEEN_NOTE]
    if missing:
        md += ["", f"Missing: {', '.join(missing)} weights. Train the RGP peer with "
               "`ndrql train --model rgp --epochs 7 --run-dir ~/.cache/ndrql/runs/rgp` (or set NDRQL_RGP_WEIGHTS)."]
        log(f"table1: no weights for {', '.join(missing)}")
    return write_table(out_dir, "table1", md, numbers)
