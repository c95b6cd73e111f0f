"""Regenerate the shipped ONNX graphs from the shipped checkpoints (run after new weights land).

    python tools/export_shipped_onnx.py            # every installed one: paper, general, belief (when its .pt is there)
    python tools/export_shipped_onnx.py general    # one
    python tools/export_shipped_onnx.py ndr_general_large   # a companion: its file stem in src/ndrql/data

For each model: export ``src/ndrql/data/<name>.onnx`` (any input side), measure it against torch at
every checked side (:data:`ndrql.model.shipped.CHECK_SIDES`; fails above 1e-4) and write the record
``<name>.onnx.json`` that ``tests/product/test_light_install.py`` checks against the checkpoint. A
companion (:mod:`ndrql.model.companion`: the weights a shipped model's ``merged_weights`` names) is
named by its file stem; its checkpoint must lie in ``src/ndrql/data``, and its graph and record land
beside it, where the ONNX backend finds them. Needs torch
and onnx (``pip install -e '.[train]'``). Run it from the repository root with the package's source
on the path (``PYTHONPATH=src``) so the files land in ``src/ndrql/data``.
"""

from __future__ import annotations

import os
import sys

from ndrql.errors import NdrqlError
from ndrql.model.export import export_shipped
from ndrql.model.shipped import SHIPPED_BUDGET, record_path, shipped_bytes, shipped_file
from ndrql.model.weights import SHIPPED_WEIGHTS, installed


def main(argv: list[str]) -> int:
    os.environ["NDRQL_WRITE_PACKAGE"] = "1"  # this tool refreshes files the package ships (ndrql.io.readset)
    names = argv or [n for n in SHIPPED_WEIGHTS if installed(n)]  # belief ships once trained
    unknown = [n for n in names if n not in SHIPPED_WEIGHTS and not _companion_file(n)]
    if unknown:
        print(f"unknown model {unknown[0]!r}; valid: {', '.join(SHIPPED_WEIGHTS)}, or the file stem of a "
              f"companion checkpoint in src/ndrql/data", file=sys.stderr)
        return 2
    missing = [n for n in names if n in SHIPPED_WEIGHTS and not installed(n)]
    if missing:
        print(f"no checkpoint {shipped_file(missing[0])} to export", file=sys.stderr)
        return 2
    for name in names:
        record = export_shipped(name)
        worst = {side: max(d.values()) for side, d in record["max_abs_difference"].items()}
        print(f"{name}: {record_path(name)} ({record['onnx_bytes'] / 1e6:.1f} MB); max |ONNX - torch| per side: "
              + ", ".join(f"{side} {v:.1e}" for side, v in worst.items()))
    total = shipped_bytes()
    print(f"all shipped weights: {total / 1e6:.1f} MB (budget {SHIPPED_BUDGET / 1e6:.0f} MB)")
    return 0 if total <= SHIPPED_BUDGET else 1


def _companion_file(name: str) -> bool:
    """Whether ``name`` is the stem of a checkpoint in the data folder."""
    try:
        return shipped_file(name).is_file()
    except NdrqlError:
        return False


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
