"""Train/validation split of TRAIN by map, holding out no map that TEST/SEEN uses.

TRAIN has 4000 map files but only ~3082 distinct maps, and every TEST/SEEN map is a TRAIN map
(data/README.md). Maps are grouped by content; validation draws whole groups, never one whose map
appears in TEST/SEEN, so checkpoints are not picked on the seen test maps.
"""

from __future__ import annotations


import numpy as np

from ndrql.dataset.cache import SplitArrays
from ndrql.io import data_digest


def map_hashes(maps_packed: np.ndarray) -> list[str]:
    """Content hash of each packed map."""
    return [data_digest(m, algorithm="sha1") for m in maps_packed]


def train_val_split(train: SplitArrays, seen: SplitArrays | None, val_fraction: float = 0.05, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Sample indices (train, val) of TRAIN; no map content in both, no SEEN map in val."""
    hashes = map_hashes(train.maps)
    seen_hashes = set(map_hashes(seen.maps)) if seen is not None else set()
    groups = sorted(set(hashes))
    eligible = [g for g in groups if g not in seen_hashes]
    rng = np.random.default_rng(seed)
    n_val = int(round(val_fraction * len(groups)))
    val_groups = set(rng.choice(eligible, size=min(n_val, len(eligible)), replace=False).tolist())
    is_val_map = np.array([h in val_groups for h in hashes])
    sample_val = is_val_map[train.map_index]
    return np.flatnonzero(~sample_val), np.flatnonzero(sample_val)
