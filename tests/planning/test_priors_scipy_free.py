"""The priors' scipy-free helpers give scipy's answers exactly (plan no longer imports ``scipy.ndimage``)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from ndrql.planning import priors as P


@pytest.mark.parametrize("seed", range(40))
def test_gaussian_blur_is_scipys_gaussian_filter_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    h, w = (int(v) for v in rng.integers(1, 90, 2))  # includes lines shorter than the kernel (radius 6)
    values = rng.random((h, w)) * (rng.random((h, w)) < 0.3)
    for sigma in (P.GUIDELINE_BLUR, 0.7, 2.0):
        ours = P.gaussian_blur(values, sigma)
        theirs = ndimage.gaussian_filter(values, sigma)
        assert ours.dtype == np.float64 and ours.shape == values.shape
        assert np.array_equal(ours.view(np.uint64), theirs.view(np.uint64))


def test_gaussian_blur_of_a_single_cell_by_hand():
    one = np.zeros((1, 1))
    one[0, 0] = 2.0
    assert P.gaussian_blur(one, 1.5)[0, 0] == pytest.approx(2.0)  # a 1x1 line reflects onto itself


@pytest.mark.parametrize("seed", range(30))
def test_region_connects_agrees_with_a_4_connected_labelling(seed):
    rng = np.random.default_rng(100 + seed)
    h, w = (int(v) for v in rng.integers(3, 40, 2))
    blocked = rng.random((h, w)) < 0.25
    region = rng.random((h, w))
    start, goal = (0, 0), (h - 1, w - 1)
    blocked[start] = blocked[goal] = False
    for thd in (0.0, 0.2, 0.5):
        inside = (region > thd) & ~blocked
        labels, _ = ndimage.label(inside, structure=ndimage.generate_binary_structure(2, 1))
        expected = bool(inside[start] and inside[goal] and labels[start] == labels[goal])
        assert P.region_connects(region, blocked, start, goal, thd) == expected


def test_a_diagonal_touch_does_not_connect_a_region():
    region = np.array([[1.0, 0.0], [0.0, 1.0]])
    assert not P.region_connects(region, np.zeros((2, 2), bool), (0, 0), (1, 1), 0.5)
