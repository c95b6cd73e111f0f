#!/usr/bin/env python3
"""``ndrql train`` with the training mixture rendering grids under a view (``ndrql train`` has no ``--view`` yet).

    OMP_NUM_THREADS=1 PYTHONPATH=src nice -n 10 python studies/large_view/finetune.py coarse:128 \\
        --sources ~/.cache/ndrql/gen/ft-large-s3:1 --input-mode grid --grid-sizes 64,100,128,160,200,256,256 \\
        --init-weights src/ndrql/data/ndr_general.pt --distance-head --distance-decoder skips \\
        --distance-rank raw+snapped --epochs 1 --steps-per-epoch 240 --lr 3e-4 --warmup-steps 20 \\
        --threads 1 --batch-size 16 --val-per-source 48 --checkpoint-minutes 3 --no-progress \\
        --run-dir ~/.cache/ndrql/runs/ft-large-coarse128

The first argument is the view (``ndrql.dataset.views.GridView``); the rest are ``ndrql train``'s. The
checkpoint does not record the view: evaluate it with ``measure.py --weights RUN/best.pt --views VIEW``.
"""

from __future__ import annotations

import sys

import ndrql.dataset.mixture as mixture
from ndrql.dataset.views import GridView


def main(argv: list[str]) -> int:
    view = GridView.parse(argv[0])

    class ViewMixture(mixture.Mixture):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs, view=view)

    mixture.Mixture = ViewMixture  # build_mixture imports it from the module at call time
    from ndrql.cli import main as cli

    return cli(["train", *argv[1:]])


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
