"""The dataset layout through ``ndrql.dataset.layout.load_sample``: every anomaly of data/README.md,
checked on the real files (skipped when ../shared/data is absent)."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.errors import DatasetError
from ndrql.maps import load_map

pytestmark = pytest.mark.data
layout = pytest.importorskip("ndrql.dataset.layout")


def test_x_is_the_row(dataset_root):
    s = layout.load_sample(dataset_root, "seen", 0)
    assert (s.start, s.goal) == ((31, 22), (159, 166))  # file: "31, 22, 159, 166" -> x = row
    assert not s.map[s.start] and not s.map[s.goal]
    assert 0 <= s.start[0] <= 100 <= s.goal[0] <= 200  # README: start row 0..100, goal row 100..200


def test_train_sample_uses_map_i_mod_4000(dataset_root):
    a = layout.load_sample(dataset_root, "train", 4005)
    b = layout.load_sample(dataset_root, "train", 5)
    assert a.map_index == 5
    np.testing.assert_array_equal(a.map, b.map)
    raw = load_map(dataset_root / "TRAIN" / "MAP [ORIGINAL]" / "5.jpg")
    np.testing.assert_array_equal(a.map, raw.obstacles)
    assert (a.start, a.goal) != (b.start, b.goal)


def test_unseen_256px_maps_resized_like_cv2(dataset_root):
    cv2 = pytest.importorskip("cv2")
    from PIL import Image

    gray = np.asarray(Image.open(dataset_root / "TEST" / "UNSEEN" / "MAP [ORIGINAL]" / "1000.jpg").convert("L"))
    assert gray.shape == (256, 256)
    s = layout.load_sample(dataset_root, "unseen", 1000)
    assert s.map.shape == (201, 201)
    np.testing.assert_array_equal(s.map, cv2.resize(gray, (201, 201)) <= 127)


def test_unseen_900_waypoints_reordered_and_reproduce_the_guideline(dataset_root):
    cv2 = pytest.importorskip("cv2")
    s = layout.load_sample(dataset_root, "unseen", 1000)
    assert tuple(s.waypoints[0]) == s.start and tuple(s.waypoints[-1]) == s.goal
    img = np.zeros((201, 201), np.uint8)
    for (r0, c0), (r1, c1) in zip(s.waypoints[:-1], s.waypoints[1:]):
        cv2.line(img, (int(c0), int(r0)), (int(c1), int(r1)), 255, thickness=2)
    np.testing.assert_array_equal(img > 0, s.guideline)


def test_broken_unseen_region_labels_regenerated(dataset_root):
    s = layout.load_sample(dataset_root, "unseen", 1000)
    assert s.region.shape == (201, 201)
    assert s.region_original is not None and s.region_original.shape == (256, 256)
    ok = layout.load_sample(dataset_root, "seen", 0)  # a valid label equals the same dilation rule
    assert ok.region_original is None
    np.testing.assert_array_equal(layout.dilate_region(ok.guideline), ok.region)
    np.testing.assert_array_equal(layout.dilate_region(s.guideline), s.region)


@pytest.mark.parametrize("split, index, category", [
    ("train", 0, "GAPS"), ("train", 5999, "BUGTRAP&BLOCKS"), ("seen", 899, "BLOCKS"),
    ("seen", 900, "GAPS&BLOCKS"), ("unseen", 600, "MAZE"), ("unseen", 1199, "NARROW PASSAGE"),
])
def test_category_from_index_block(dataset_root, split, index, category):
    s = layout.load_sample(dataset_root, split, index)
    assert s.category == category
    assert 150.0 <= s.cost <= 600.0


def test_dataset_errors(dataset_root, tmp_path):
    with pytest.raises(DatasetError):
        layout.load_sample(dataset_root, "test", 0)
    with pytest.raises(DatasetError):
        layout.load_sample(dataset_root, "seen", 1200)
    with pytest.raises(DatasetError):
        layout.load_sample(tmp_path, "seen", 0)
