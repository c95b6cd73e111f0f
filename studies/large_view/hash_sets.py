#!/usr/bin/env python3
"""Generate the large-grid evaluation sets into the cache and print the digest of each one's contents.

    PYTHONPATH=src python studies/large_view/hash_sets.py large-dev-128 large-dev-256 sealed-large-128 sealed-large-256

The digest is the SHA-256 of every sample in order: its bit-packed map, its side, start and goal, and its
waypoints (``ndrql.io.data_digest``); it names the maps themselves, whatever the cache's file layout. This
script only generates and hashes: it never predicts or plans on a set.
"""

from __future__ import annotations

import sys

import numpy as np

from ndrql.experiments.eval_sets import eval_set, registry
from ndrql.io import data_digest


def set_digest(name: str) -> tuple[str, int]:
    """(digest, sample count) of the registered set ``name`` (generated into the cache on first use; a sealed
    set too: hashing reads no prediction and no plan, as ``tools/seal_sets.py``)."""
    gs = eval_set(registry()[name].spec, progress=False, release=True)
    parts = []
    for i in range(len(gs)):
        raw = gs.raw(i)
        parts += [np.packbits(raw.obstacles), np.array([raw.obstacles.shape[0], *raw.start, *raw.goal], np.int64),
                  np.asarray(raw.waypoints, np.int64)]
    return data_digest(*parts), len(gs)


def main(names: list[str]) -> int:
    for name in names:
        digest, count = set_digest(name)
        print(f"{name}\t{count} maps\tsha256 {digest}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
