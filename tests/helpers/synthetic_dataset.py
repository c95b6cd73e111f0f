"""Write a tiny dataset in the original layout (data/README.md) for tests that must not need the real one."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from ndrql.dataset.layout import (COST_DIR, GUIDE_DIR, MAP_DIR, POINTS_DIR, REGION_DIR, SPLITS, WAYPOINTS_DIR,
                                  dilate_region)
from ndrql.maps.grid import MODEL_SIDE as SIDE


def draw_polyline(points: np.ndarray, side: int = SIDE) -> np.ndarray:
    """A 2 px polyline through ``points`` (row, col), the dataset's guideline style (approximately)."""
    img = np.zeros((side, side), bool)
    for (r0, c0), (r1, c1) in zip(points[:-1], points[1:]):
        n = int(max(abs(r1 - r0), abs(c1 - c0))) + 1
        rr = np.linspace(r0, r1, n).round().astype(int)
        cc = np.linspace(c0, c1, n).round().astype(int)
        img[rr, cc] = True
        img[np.minimum(rr + 1, side - 1), cc] = True
    return img


def write_sample(base: Path, i: int, rng: np.random.Generator, map_index: int | None = None) -> None:
    """One sample: a map with a few blocks, start top-left-ish, goal bottom-right-ish, a 3-point path."""
    free = np.ones((SIDE, SIDE), np.uint8) * 255
    for _ in range(3):
        r, c = rng.integers(40, 160, size=2)
        free[r:r + 15, c:c + 15] = 0
    start = (int(rng.integers(5, 40)), int(rng.integers(5, 60)))
    goal = (int(rng.integers(160, 196)), int(rng.integers(140, 196)))
    free[max(0, start[0] - 3):start[0] + 4, max(0, start[1] - 3):start[1] + 4] = 255
    free[goal[0] - 3:goal[0] + 4, goal[1] - 3:goal[1] + 4] = 255
    mid = (start[0], goal[1])
    free[start[0] - 1:start[0] + 2, :] = 255
    free[:, goal[1] - 1:goal[1] + 2] = 255
    wp = np.array([start, mid, goal])
    guide = draw_polyline(wp)
    region = dilate_region(guide)
    if map_index is None or map_index == i:
        Image.fromarray(free).convert("RGB").save(base / MAP_DIR / f"{i}.jpg", quality=95)
    (base / POINTS_DIR / f"{i}.txt").write_text("".join(f"{v}\n" for v in (*start, *goal)))
    (base / WAYPOINTS_DIR / f"{i}.txt").write_text("".join(f"{v}\n" for v in wp.ravel()))
    Image.fromarray(guide.astype(np.uint8) * 255).save(base / GUIDE_DIR / f"{i}.jpg", quality=95)
    Image.fromarray(region.astype(np.uint8) * 255).convert("RGB").save(base / REGION_DIR / f"{i}.jpg", quality=95)
    (base / COST_DIR / f"{i}.txt").write_text(str(float(np.hypot(*np.diff(wp, axis=0).T).sum())))


def make_tiny_dataset(root: Path, n_train: int = 24, n_test: int = 8, seed: int = 0) -> Path:
    """Create ``root`` with TRAIN (n_train samples, one map each) and both TEST splits."""
    rng = np.random.default_rng(seed)
    for split, n in (("train", n_train), ("seen", n_test), ("unseen", n_test)):
        base = root / SPLITS[split]
        for d in (MAP_DIR, POINTS_DIR, WAYPOINTS_DIR, GUIDE_DIR, REGION_DIR, COST_DIR):
            (base / d).mkdir(parents=True, exist_ok=True)
        for i in range(n):
            write_sample(base, i, rng)
    return root
