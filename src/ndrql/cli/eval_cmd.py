"""``ndrql eval``: region and guideline F1 of a model on TEST/SEEN, TEST/UNSEEN or the validation split.

F1 as in the paper (docs/method.md): threshold 0.5, pixel-wise per image, mean over the split, also per category.
On UNSEEN the 300 NARROW PASSAGE region labels are broken upstream; the main column uses the labels
regenerated from the guideline, and an extra column scores against the original (upstream) labels.
With --prior-from oracle the oracle's arrays (an 8-connected shortest path of the safe planning grid with
shortcuts, drawn like the dataset's labels) are scored in place of a model, as a grid-mode model is: the best a prediction on
that grid can score against the dataset's labels (a diagnostic, not a model).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ndrql.cli.common import add_symmetries_argument, add_weights_argument, check_outputs, write_json
from ndrql.dataset.cache import load_split
from ndrql.dataset.layout import CATEGORIES, check_root, default_root
from ndrql.dataset.splits import train_val_split
from ndrql.errors import DatasetError, NdrqlError
from ndrql.io import write_text
from ndrql.limits import MAX_GRID_SIZE, MIN_GRID_SIZE, MAX_THREADS, check_int
from ndrql.maps.grid import PLANNING_SIZE
from ndrql.model.weights import resolve_weights
from ndrql.synth.oracle import ORACLE_NAME, PRIOR_SOURCES

EXAMPLES = """examples:
  ndrql eval --split seen
  ndrql eval --split unseen --weights ~/.cache/ndrql/runs/ndr-default/best.pt --markdown out/unseen.md
  ndrql eval --split val --weights ~/.cache/ndrql/runs/ndr-default/best.pt
  ndrql eval --split unseen --weights general --symmetries 4   # as ndrql plan predicts
  ndrql eval --split unseen --prior-from oracle --json out/oracle.json   # the oracle's arrays, no model
"""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("eval", help="F1 of the NDR model on seen/unseen/val", description=__doc__, epilog=EXAMPLES,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--split", choices=("seen", "unseen", "val"), default="seen", help="split to score (default: seen)")
    add_weights_argument(p)
    p.add_argument("--data", metavar="DIR", help="dataset root (default: $NDRQL_DATASET, else a path-planning-dataset folder in the working directory)")
    p.add_argument("--batch-size", type=int, default=32, help="images per forward pass (default: 32)")
    p.add_argument("--limit", type=int, default=0, help="score only the first N samples (0 = all)")
    p.add_argument("--threads", type=int, default=0, help="torch threads (0 = all cores)")
    p.add_argument("--grid", type=int, default=PLANNING_SIZE, metavar="N",
                   help=f"grid-mode models: planning grid the model sees (default: {PLANNING_SIZE}, the paper's); "
                   "ignored for map-mode models")
    p.add_argument("--prior-from", choices=PRIOR_SOURCES, default="model",
                   help="score the model (--weights) or the oracle's arrays on the safe --grid (seen/unseen; named "
                   "'oracle priors' in the output) (default: model)")
    add_symmetries_argument(p, "a grid-mode model's predictions averaged over N orientations of the grid "
                               "(ndrql plan uses 1 unless told; the F1 tables of docs/results.md use 1; ignored for map-mode models)", 1)
    p.add_argument("--markdown", metavar="FILE", help="also write the table as markdown")
    p.add_argument("--json", metavar="FILE", help="also write the numbers as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import numpy as np
    import torch

    from ndrql.model.checkpoint import load_checkpoint, model_from_checkpoint  # lazy: loads torch
    from ndrql.training.evaluate import category_rows, evaluate, markdown_table  # lazy: loads torch

    check_int(args.batch_size, "--batch-size", 1, 4096)
    check_int(args.limit, "--limit", 0)
    check_int(args.threads, "--threads", 0, MAX_THREADS)

    check_outputs(args.markdown, args.json)
    if args.prior_from == "oracle":
        if args.weights:
            raise NdrqlError("give either --weights or --prior-from oracle, not both")
        if args.symmetries != 1:
            raise NdrqlError("--symmetries averages a model's predictions; the oracle's arrays are not predicted")
        if args.split == "val":
            raise NdrqlError("--split val is a model's own validation split; with --prior-from oracle use seen or unseen")
        check_int(args.grid, "--grid", MIN_GRID_SIZE, MAX_GRID_SIZE)
    root = args.data or default_root()
    if root is None:
        raise DatasetError("no dataset found: pass --data DIR (the path-planning-dataset in its original layout)")
    check_root(root)
    if args.prior_from == "oracle":
        return _eval_oracle(args, root)
    if args.threads:
        torch.set_num_threads(args.threads)
    weights = resolve_weights(args.weights)
    ck = load_checkpoint(weights)
    model = model_from_checkpoint(ck).to(memory_format=torch.channels_last)
    encoding = dict(ck["config"]).get("encoding", "point")
    if args.split == "val":
        tc = dict(ck.get("train_config", {}))
        data = load_split(root, "train")
        _, indices = train_val_split(data, load_split(root, "seen"), tc.get("val_fraction", 0.05), tc.get("seed", 0))
        names = CATEGORIES["train"]
    else:
        data = load_split(root, args.split)
        indices = np.arange(len(data))
        names = CATEGORIES[args.split]
    if args.limit:
        indices = indices[:args.limit]
    mode = dict(ck["config"]).get("input_mode", "map")
    title = f"{args.split} ({len(indices)} samples, weights {weights.name})"
    if mode == "grid":
        from ndrql.experiments.grid_eval import evaluate_grid_model  # lazy: loads torch and scipy and tqdm

        check_int(args.grid, "--grid", MIN_GRID_SIZE, MAX_GRID_SIZE)
        ge = evaluate_grid_model(model, data, indices, n=args.grid, encoding=encoding,
                                 batch_size=min(args.batch_size, 16), progress=True, symmetries=args.symmetries)
        res = ge.dataset
        rows = category_rows(res, names, grid=(ge.grid_region_f1, ge.grid_guideline_f1))
        title += (f"; grid-mode model on the safe {args.grid}x{args.grid} grid (larger where start and goal need it: "
                  f"{int((ge.sizes > args.grid).sum())} maps), each map pixel scored with its cell's mean"
                  + (f", averaged over {args.symmetries} orientations of the grid" if args.symmetries > 1 else ""))
    else:
        res = evaluate(model, data, indices, batch_size=args.batch_size, encoding=encoding, progress=True)
        rows = category_rows(res, names)
    table = markdown_table(rows, title, args.split == "unseen")
    print(table)
    print(f"throughput: {res.images_per_s:.1f} images/s (batch {args.batch_size}, fp32, {torch.get_num_threads()} threads)")
    if args.markdown:
        write_text(args.markdown, table)
    if args.json:
        write_json(args.json, {"split": args.split, "weights": str(weights), "prior_from": "model", "input_mode": mode,
                                "grid": args.grid if mode == "grid" else None, "rows": rows,
                                "symmetries": args.symmetries if mode == "grid" else 1,
                                "images_per_s": res.images_per_s})
    return 0


def _eval_oracle(args: argparse.Namespace, root) -> int:
    """``--prior-from oracle``: the oracle's arrays scored as a grid-mode model's predictions."""
    import numpy as np

    from ndrql.experiments.grid_eval import evaluate_oracle  # lazy: loads torch and scipy and tqdm
    from ndrql.training.evaluate import category_rows, markdown_table  # lazy: loads torch

    data = load_split(root, args.split)
    indices = np.arange(len(data))[:args.limit or None]
    ge = evaluate_oracle(data, indices, n=args.grid, batch_size=min(args.batch_size, 16), progress=True)
    rows = category_rows(ge.dataset, CATEGORIES[args.split], grid=(ge.grid_region_f1, ge.grid_guideline_f1))
    title = (f"{args.split} ({len(indices)} samples, oracle priors); the oracle's arrays on the safe {args.grid}x{args.grid} "
             f"grid (larger where start and goal need it: {int((ge.sizes > args.grid).sum())} maps): an 8-connected shortest "
             "path of the grid with shortcuts, drawn like the dataset's labels, each map pixel scored with its cell's mean")
    table = markdown_table(rows, title, args.split == "unseen")
    print(table)
    if args.markdown:
        write_text(args.markdown, table)
    if args.json:
        write_json(args.json, {"split": args.split, "weights": ORACLE_NAME, "prior_from": "oracle",
                               "input_mode": "grid", "grid": args.grid, "rows": rows})
    return 0
