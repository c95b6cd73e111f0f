"""The sizing comparison (docs/model.md): validation F1 per training hour by model width and precision.

Each run of :data:`SIZING_RUNS` is ``ndrql train --threads 1`` with the same data order, augmentation
and schedule length (``tools/train_comparisons.sh``); its learning curve comes from its
``metrics.csv`` and its best checkpoint is scored on the test splits (:mod:`ndrql.experiments.model_runs`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from ndrql.experiments.model_runs import checkpoint_summary, evaluate_weights, read_metrics, run_status, runs_root
from ndrql.dataset.layout import resolve_root
from ndrql.experiments.report import fmt_f1, machine, machine_line, md_table, save_figure, write_table
from ndrql.viz.reproduce import sizing_figure

#: The sizing comparison (docs/model.md): run directory under the runs root -> what it varies.
SIZING_RUNS = (
    ("width/quarter", "quarter width (0.25), bf16"),
    ("table4/point+GD", "half width (0.5, the default), bf16"),
    ("width/full", "full width (1.0), bf16"),
    ("precision/half-fp32", "half width (0.5), fp32"),
)


def sizing(out_dir: str | Path, runs: str | Path | None = None, command: str = "", data: str | None = None,
           limit: int | None = None, progress: bool = True, log: Callable[[str], None] = print) -> Path:
    """Validation F1 against training hours for the model sizes and precisions of :data:`SIZING_RUNS`,
    and each run's best checkpoint scored on TEST/SEEN and TEST/UNSEEN."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    root = resolve_root(data)
    runs = Path(runs) if runs else runs_root()
    rows, numbers, curves = [], {}, []
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
        curves.append((label, metrics))
        rows.append([label, fmt_f1(params), fmt_f1(sec_per_step), f"{int(last['epoch'])}/{st['epochs']}",
                     fmt_f1(last["train_hours"]), fmt_f1(last["val_region_f1"]), fmt_f1(last["val_guideline_f1"]),
                     f"{fmt_f1(test['seen']['region_f1'])} / {fmt_f1(test['seen']['guideline_f1'])}",
                     f"{fmt_f1(test['unseen']['region_f1'])} / {fmt_f1(test['unseen']['guideline_f1'])}", f"`{name}`"])
    save_figure(sizing_figure(curves), out_dir / "sizing.png")
    md = ["# sizing: validation F1 per training hour, by model width and precision", "", f"Command: `{command}`", "",
          f"Machine: {machine_line(machine())}.", "",
          "Each run: `ndrql train --threads 1` with the same data order, augmentation and schedule length "
          "(tools/train_comparisons.sh); every width with the same 8-channel guideline UNet, so only the backbone "
          "width changes. Validation: 462 samples of held-out TRAIN maps (no SEEN map). Figure: sizing.png.", "",
          md_table(["run", "params (M)", "s/step", "epochs", "train h", "val R", "val G", "seen R / G", "unseen R / G",
                    "run dir"], rows), "", "val: last epoch; seen/unseen: the run's best checkpoint on the full test "
          "sets (unseen with the regenerated NARROW PASSAGE labels)."]
    return write_table(out_dir, "sizing", md, numbers)
