"""The exact source's drawing (pipeline/sources.py, maps/route_cells.py) against plain reference loops: the window and the cell means
that make its region and guideline, and the region against the oracle's OpenCV-style drawing."""

from __future__ import annotations

import numpy as np

from ndrql.dataset.render import cell_means
from ndrql.maps import route_cells
from ndrql.maps.grid import bfs_distances
from ndrql.pipeline import sources as S
from ndrql.synth.oracle import oracle_prediction


def _window_ref(a: np.ndarray, before: int, after: int, axis: int) -> np.ndarray:
    a = np.moveaxis(a, axis, 0)
    n = a.shape[0]
    out = np.zeros_like(a)
    for i in range(n):
        out[i] = a[max(0, i - before):min(n, i + after + 1)].any(axis=0)
    return np.moveaxis(out, 0, axis)


def test_window_and_cell_means_equal_plain_loops():
    rng = np.random.default_rng(0)
    for _ in range(150):
        h, w = (int(v) for v in rng.integers(1, 40, 2))
        a = rng.random((h, w)) < rng.random() * 0.3
        before, after, axis = int(rng.integers(0, 16)), int(rng.integers(0, 16)), int(rng.integers(0, 2))
        assert np.array_equal(route_cells.window_any(a, before, after, axis), _window_ref(a, before, after, axis))
        img = rng.random((4 * int(rng.integers(1, 12)), 4 * int(rng.integers(1, 12)))) < 0.5
        ref = img.reshape(img.shape[0] // 4, 4, img.shape[1] // 4, 4).mean(axis=(1, 3))
        assert np.array_equal(route_cells.cell_means(img, 4), ref)


def test_exact_region_is_the_labels_drawing_to_a_pixel():
    """Region and guideline per cell differ from the oracle's (OpenCV's line rule, numba) by at most a pixel of a
    cell's 16 here and there; the route cells are the same."""
    blocked = np.zeros((40, 40), bool)
    blocked[20, 2:38] = True
    got = S.drawn_priors("exact", blocked, (3, 5), (36, 30), None)
    region, guide = oracle_prediction(blocked, (3, 5), (36, 30), 4)
    r, gl = cell_means(region, blocked.shape), cell_means(guide, blocked.shape)
    assert np.abs(got.region - r).max() <= 0.25 and np.abs(got.region - r).mean() < 0.01
    assert np.abs(got.guideline - gl).max() <= 0.25 and np.abs(got.guideline - gl).mean() < 0.01
    free = ~blocked
    assert np.array_equal(got.distance[free], bfs_distances(blocked, (36, 30))[free].astype(float))
