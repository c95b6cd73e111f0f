"""The O(pixels) planning-grid downscale and model-input resize agree exactly with the dense forms they replace."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.maps.grid import _overlap_matrix, _overlap_sums, area_downscale, area_sums, planning_grid


def dense_planning_grid(arr: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """The previous implementation: dense overlap matrices, exact integer products."""
    h_in, w_in = arr.shape
    rows = _overlap_matrix(h_in, shape[0])
    cols = _overlap_matrix(w_in, shape[1])
    return 2 * (rows @ arr.astype(np.int64) @ cols.T) >= h_in * w_in


def dense_area_downscale(arr: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    h_in, w_in = arr.shape
    rows = _overlap_matrix(h_in, shape[0]).astype(np.float64)
    cols = _overlap_matrix(w_in, shape[1]).astype(np.float64)
    return (rows @ arr @ cols.T) / float(h_in * w_in)


@pytest.mark.parametrize("n_in", [1, 2, 3, 7, 50, 201, 256, 333])
@pytest.mark.parametrize("n_out", [1, 2, 3, 50, 64, 201, 400])
def test_overlap_sums_equal_the_dense_product(n_in, n_out):
    x = np.random.default_rng(n_in * 1000 + n_out).integers(0, 7, (n_in, 5))
    np.testing.assert_array_equal(_overlap_sums(x, n_out, 0, np.int64), _overlap_matrix(n_in, n_out) @ x)
    np.testing.assert_array_equal(_overlap_sums(x.T, n_out, 1, np.int64), (_overlap_matrix(n_in, n_out) @ x).T)


def test_planning_grid_equals_the_dense_form_on_random_maps():
    rng = np.random.default_rng(0)
    for _ in range(60):
        h, w = rng.integers(1, 300, 2)
        size = (int(rng.integers(1, 260)), int(rng.integers(1, 260)))
        arr = rng.random((h, w)) < rng.uniform(0.05, 0.95)
        np.testing.assert_array_equal(planning_grid(arr, size), dense_planning_grid(arr, size))


def test_area_downscale_separable_form_agrees_with_the_dense_form():
    rng = np.random.default_rng(1)
    arr = rng.random((1500, 1100))  # above the dense budget: separable form
    out = area_downscale(arr, (64, 48))
    np.testing.assert_allclose(out, dense_area_downscale(arr, (64, 48)), rtol=0, atol=1e-12)
    small = rng.random((201, 201))  # the paper's 201 -> 50 keeps the dense form: bit-identical
    np.testing.assert_array_equal(area_downscale(small, (50, 50)), dense_area_downscale(small, (50, 50)))


def test_area_sums_of_a_long_thin_map_are_linear_in_its_pixels():
    arr = np.zeros((1, 2_000_000), dtype=bool)
    arr[0, ::3] = True
    sums = area_sums(arr, (1, 256))
    assert sums.shape == (1, 256) and int(sums.sum()) == int(arr.sum()) * 256  # every pixel counted once


@pytest.mark.data
def test_planning_grid_is_unchanged_on_every_test_seen_map(dataset_root):
    from ndrql.dataset.layout import count_samples, load_map, load_sample

    n = count_samples(dataset_root, "seen")
    for i in range(n):
        arr = load_map(dataset_root, "seen", i)
        np.testing.assert_array_equal(planning_grid(arr), dense_planning_grid(arr, (50, 50)), err_msg=f"SEEN {i}")
    for i in range(0, n, 97):  # label images through the float path (dense budget: bit-identical)
        s = load_sample(dataset_root, "seen", i)
        for a in (s.region.astype(float), s.guideline.astype(float)):
            np.testing.assert_array_equal(area_downscale(a), dense_area_downscale(a, (50, 50)))


def _old_to_model_input_map(obstacles: np.ndarray, side: int = 201) -> np.ndarray:
    """The model input resize before it became O(pixels) (np.add.at over every pixel)."""
    h, w = obstacles.shape
    scale = side / max(h, w)
    nh, nw = max(1, round(h * scale)), max(1, round(w * scale))
    rows = np.minimum((np.arange(h) * nh) // h, nh - 1)
    cols = np.minimum((np.arange(w) * nw) // w, nw - 1)
    sums = np.zeros((nh, nw))
    counts = np.zeros((nh, nw))
    np.add.at(sums, (rows[:, None], cols[None, :]), obstacles.astype(np.float64))
    np.add.at(counts, (rows[:, None], cols[None, :]), 1.0)
    out = np.ones((side, side), bool)
    out[:nh, :nw] = sums / np.maximum(counts, 1) >= 0.5
    return out


@pytest.mark.parametrize("shape", [(402, 402), (300, 1000), (1000, 333), (203, 202), (4000, 17)])
def test_model_input_resize_is_unchanged(shape):
    from ndrql.dataset.render import to_model_input

    arr = np.random.default_rng(shape[0] + shape[1]).random(shape) < 0.4
    arr[0, 0] = arr[-1, -1] = False
    out, _, _, _ = to_model_input(arr, (0, 0), (shape[0] - 1, shape[1] - 1))
    np.testing.assert_array_equal(out, _old_to_model_input_map(arr))


@pytest.mark.parametrize("width", [1, 7, 8, 9, 64, 1001])
@pytest.mark.parametrize("group", [1, 3, 255, 256, 300])
def test_packed_group_sums_equal_reduceat(width, group):
    from ndrql.maps.area import group_sums

    rng = np.random.default_rng(width * 7 + group)
    x = (rng.random((3 * group + 5, width)) < 0.9).view(np.uint8)  # dense ones: byte lanes near their limit
    starts = np.array([0, group, 2 * group, 3 * group])
    np.testing.assert_array_equal(group_sums(x, starts, 0, np.int32), np.add.reduceat(x, starts, axis=0, dtype=np.int32))
    sliced = x[:, ::2] if width > 1 else x  # not contiguous along the row: the plain path
    np.testing.assert_array_equal(group_sums(sliced, starts, 0, np.int64),
                                  np.add.reduceat(sliced, starts, axis=0, dtype=np.int64))


def test_a_one_row_map_is_narrowed_before_it_is_widened():
    import tracemalloc

    arr = np.zeros((1, 4_000_000), dtype=bool)
    arr[0, ::7] = True
    tracemalloc.start()
    g = planning_grid(arr, 50)  # 50 x 50 cells stretched over one pixel row
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert g.shape == (50, 50) and not g.any()  # 1 pixel in 7 is obstacle: every cell below half
    assert peak < 8 * arr.size  # well below the 50 x 4 M intermediate of the rows-first order
    np.testing.assert_array_equal(planning_grid(arr[:, :4000], 50), dense_planning_grid(arr[:, :4000], (50, 50)))


def test_the_two_resize_rules_agree_when_sizes_divide_and_differ_at_straddled_pixels():
    from ndrql.maps.area import pixel_bins, whole_pixel_majority

    arr = np.random.default_rng(5).random((402, 804)) < 0.4
    np.testing.assert_array_equal(whole_pixel_majority(arr, (201, 201)), planning_grid(arr, (201, 201)))
    one = np.array([[False, True, False]])  # three pixels to two cells: the middle one straddles them
    assert pixel_bins(3, 2).tolist() == [0, 0, 1]
    assert whole_pixel_majority(one, (1, 2)).tolist() == [[True, False]]  # cell 0 holds pixels 0 and 1 whole
    assert planning_grid(one, (1, 2)).tolist() == [[False, False]]  # half a pixel in 1.5: a third of each cell
    assert whole_pixel_majority(np.array([[True, False]]), (1, 4)).tolist() == [[True, True, False, False]]
