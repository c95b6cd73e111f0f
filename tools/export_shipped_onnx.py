"""Regenerate the shipped ONNX graphs from the shipped checkpoints (run after new weights land).

    python tools/export_shipped_onnx.py            # both: paper and general
    python tools/export_shipped_onnx.py general    # one

For each model: export ``src/ndrql/data/<name>.onnx`` (any input side), measure it against torch at
every checked side (:data:`ndrql.model.shipped.CHECK_SIDES`; fails above 1e-4) and write the record
``<name>.onnx.json`` that ``tests/test_shipped_onnx.py`` checks against the checkpoint. Needs torch
and onnx (``pip install -e '.[train]'``). Run it from the repository root with the package's source
on the path (``PYTHONPATH=src``) so the files land in ``src/ndrql/data``.
"""

from __future__ import annotations

import sys

from ndrql.model.export import export_shipped
from ndrql.model.shipped import SHIPPED_BUDGET, record_path, shipped_bytes
from ndrql.model.weights import SHIPPED_WEIGHTS


def main(argv: list[str]) -> int:
    names = argv or list(SHIPPED_WEIGHTS)
    unknown = [n for n in names if n not in SHIPPED_WEIGHTS]
    if unknown:
        print(f"unknown model {unknown[0]!r}; valid: {', '.join(SHIPPED_WEIGHTS)}", file=sys.stderr)
        return 2
    for name in names:
        record = export_shipped(name)
        worst = {side: max(d.values()) for side, d in record["max_abs_difference"].items()}
        print(f"{name}: {record_path(name)} ({record['onnx_bytes'] / 1e6:.1f} MB); max |ONNX - torch| per side: "
              + ", ".join(f"{side} {v:.1e}" for side, v in worst.items()))
    total = shipped_bytes()
    print(f"all shipped weights: {total / 1e6:.1f} MB (budget {SHIPPED_BUDGET / 1e6:.0f} MB)")
    return 0 if total <= SHIPPED_BUDGET else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
