"""Ship a propagating head: copy its checkpoint to ``src/ndrql/data/propagator.pt``, export the ONNX graph beside it
and write the record ``propagator.json`` that :mod:`ndrql.model.propagation` checks.

    PYTHONPATH=src python tools/export_propagator.py ~/.cache/ndrql/propagate/p6.pt

Fails (exit 1) when ONNX Runtime's probabilities differ from torch's by more than 1e-4 (64 iterations on a random
grid). Needs torch and onnx (``pip install -e '.[train]'``). Run from the repository root.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import torch

from ndrql.io import atomic_path, file_digest, write_text
from ndrql.model.propagation import graph_file, record_file
from ndrql.model.propagator import CHUNK, export_propagator, load_propagator

TOLERANCE = 1e-4


def main(argv: list[str]) -> int:
    os.environ["NDRQL_WRITE_PACKAGE"] = "1"  # this tool refreshes files the package ships (ndrql.io.readset)
    if len(argv) != 1 or not Path(argv[0]).is_file():
        print("usage: tools/export_propagator.py CHECKPOINT.pt (a file written by studies/propagate/train.py)",
              file=sys.stderr)
        return 2
    src = Path(argv[0])
    ck = torch.load(src, map_location="cpu", weights_only=True)
    net = load_propagator(src)  # checks the checkpoint loads before anything is written
    weights = graph_file().with_suffix(".pt")
    state = {k: v.clone() for k, v in net.state_dict().items()}
    keep = {"state": state, "width": int(ck["width"]), "pool": bool(ck.get("pool", False)),
            "iters": int(ck.get("iters", 0)), "step": int(ck.get("step", 0))}
    with atomic_path(weights) as tmp:
        torch.save(keep, tmp)
    worst = export_propagator(weights, graph_file())
    if worst > TOLERANCE:
        print(f"ONNX Runtime differs from torch by {worst:.1e} > {TOLERANCE:.0e}", file=sys.stderr)
        return 1
    record = {"weights_sha256": file_digest(weights), "onnx_sha256": file_digest(graph_file()), "chunk": CHUNK,
              "width": keep["width"], "pool": keep["pool"], "training_steps": keep["step"],
              "max_difference": worst, "source": src.name}
    write_text(record_file(), json.dumps(record, indent=1) + "\n")
    print(f"{graph_file()} ({graph_file().stat().st_size / 1e3:.0f} kB), max |ONNX - torch| {worst:.1e}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
