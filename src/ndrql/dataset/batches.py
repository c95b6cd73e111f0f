"""Deterministic, resumable batches from the cache, with label-consistent augmentation.

Augmentation applies one of the 8 dihedral transforms (flips and 90-degree rotations) to map,
start, goal and both labels together. Everything random derives from ``(seed, epoch)``, so a resumed
run sees exactly the batches it would have seen.
"""

from __future__ import annotations

from typing import Iterator

import numpy as np
import torch

from ndrql.dataset.cache import SplitArrays, unpack
from ndrql.dataset.encodings import encode_input

Point = tuple[int, int]


def transform_point(p: Point, k: int, shape: tuple[int, int]) -> Point:
    """Where ``p`` goes under dihedral transform ``k`` (0..7) of an (H, W) array (see transform_array)."""
    r, c = p
    h, w = shape
    if k >= 4:  # horizontal flip first
        c = w - 1 - c
    for _ in range(k % 4):  # np.rot90 (counter-clockwise): (r, c) -> (W-1-c, r), shape (H, W) -> (W, H)
        r, c = w - 1 - c, r
        h, w = w, h
    return (r, c)


def transform_array(a: np.ndarray, k: int) -> np.ndarray:
    """Dihedral transform ``k`` (0..7) of the last two axes: optional flip, then ``k % 4`` rotations."""
    if k >= 4:
        a = a[..., ::-1]
    return np.ascontiguousarray(np.rot90(a, k % 4, axes=(-2, -1)))


def sample_arrays(data: SplitArrays, i: int, k: int = 0, encoding: str = "point", original_region: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Encoded input (3, H, W), region (H, W) and guideline (H, W) of sample ``i`` under transform ``k``."""
    obstacles = data.obstacles(i)
    sr, sc, gr, gc = (int(v) for v in data.points[i])
    region = unpack(data.region_original[i] if original_region else data.region[i])
    guide = unpack(data.guideline[i])
    if k:
        shape = obstacles.shape
        obstacles, region, guide = (transform_array(a, k) for a in (obstacles, region, guide))
        start, goal = transform_point((sr, sc), k, shape), transform_point((gr, gc), k, shape)
    else:
        start, goal = (sr, sc), (gr, gc)
    return encode_input(obstacles, start, goal, encoding), region, guide


def make_batch(data: SplitArrays, indices: np.ndarray, transforms: np.ndarray | None = None, encoding: str = "point", original_region: bool = False) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Stack samples into (x, region, guideline) float tensors of shape (B, C, H, W)."""
    xs, rs, gs = [], [], []
    for j, i in enumerate(indices):
        k = 0 if transforms is None else int(transforms[j])
        x, r, g = sample_arrays(data, int(i), k, encoding, original_region)
        xs.append(x)
        rs.append(r)
        gs.append(g)
    x = torch.from_numpy(np.stack(xs))
    region = torch.from_numpy(np.stack(rs)[:, None].astype(np.float32))
    guide = torch.from_numpy(np.stack(gs)[:, None].astype(np.float32))
    return x, region, guide


def epoch_order(n: int, seed: int, epoch: int) -> tuple[np.ndarray, np.ndarray]:
    """Permutation of ``n`` samples and their dihedral transform ids for one epoch."""
    rng = np.random.default_rng([seed, epoch])
    return rng.permutation(n), rng.integers(0, 8, size=n)


def train_batches(data: SplitArrays, indices: np.ndarray, batch_size: int, seed: int, epoch: int, start_step: int = 0, augment: bool = True, encoding: str = "point") -> Iterator[tuple[int, tuple[torch.Tensor, torch.Tensor, torch.Tensor]]]:
    """Yield ``(step, batch)`` for one epoch from ``start_step`` on (drop the last partial batch)."""
    perm, ks = epoch_order(len(indices), seed, epoch)
    n_steps = len(indices) // batch_size
    for step in range(start_step, n_steps):
        sel = perm[step * batch_size:(step + 1) * batch_size]
        yield step, make_batch(data, indices[sel], ks[sel] if augment else None, encoding)
