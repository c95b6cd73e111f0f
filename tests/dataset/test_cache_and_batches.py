"""Dataset cache, splits, encodings, augmentation and the F1 metric."""

from __future__ import annotations

import os

import numpy as np
import pytest

from ndrql.dataset import cache as cache_mod
from ndrql.dataset.batches import epoch_order, make_batch, sample_arrays, transform_array, transform_point
from ndrql.dataset.encodings import ENCODINGS, encode_input, get_encoding
from ndrql.dataset.splits import map_hashes, train_val_split
from ndrql.training.metrics import f1_per_image


def test_f1_matches_hand_computation():
    pred = np.zeros((3, 4, 4), bool)
    label = np.zeros((3, 4, 4), bool)
    pred[0, 0, :3] = True  # 3 predicted
    label[0, 0, 1:] = True  # 3 true, 2 overlap -> tp 2, fp 1, fn 1 -> F1 = 4 / 6
    label[1, 2, 2] = True  # nothing predicted -> F1 0
    # image 2: both empty -> 1 by convention
    np.testing.assert_allclose(f1_per_image(pred, label), [4 / 6, 0.0, 1.0])


@pytest.mark.parametrize("k", range(8))
def test_augmentation_keeps_points_and_labels_consistent(k):
    rng = np.random.default_rng(k)
    shape = (7, 11)
    marks = np.zeros(shape, bool)
    p, q = (1, 9), (5, 2)
    marks[p] = marks[q] = True
    moved = transform_array(marks, k)
    assert moved.sum() == 2
    assert moved[transform_point(p, k, shape)] and moved[transform_point(q, k, shape)]
    other = rng.random(shape)
    assert np.array_equal(np.sort(transform_array(other, k).ravel()), np.sort(other.ravel()))


def test_encodings_put_points_where_they_belong():
    obstacles = np.zeros((21, 21), bool)
    obstacles[5, :] = True
    x = encode_input(obstacles, (2, 3), (18, 17))
    assert x.shape == (3, 21, 21) and x[1].sum() == 1 and x[1, 2, 3] == 1 and x[2, 18, 17] == 1
    assert np.array_equal(x[0] > 0, obstacles)
    rgb = encode_input(obstacles, (2, 3), (18, 17), "rgb")
    assert tuple(rgb[:, 2, 3]) == (1, 0, 0) and tuple(rgb[:, 18, 17]) == (0, 0, 1) and rgb[:, 5, 0].sum() == 0
    g = encode_input(obstacles, (2, 3), (18, 17), "gauss25")
    assert g[1].argmax() == 2 * 21 + 3 and g[1, 2, 3] == pytest.approx(1.0)
    d = encode_input(obstacles, (2, 3), (18, 17), "distance")
    assert d[2, 18, 17] == 0 and d[2].argmax() == 0
    with pytest.raises(ValueError, match="valid: " + ", ".join(ENCODINGS)):
        get_encoding("fourier")


def test_cache_round_trip_and_batches(tiny_dataset):
    from ndrql.dataset.layout import load_sample

    data = cache_mod.load_split(tiny_dataset, "train", progress=False)
    assert len(data) == 16
    s = load_sample(tiny_dataset, "train", 5)
    x, region, guide = sample_arrays(data, 5)
    assert np.array_equal(x[0] > 0, s.map)
    assert x[1, s.start[0], s.start[1]] == 1 and x[2, s.goal[0], s.goal[1]] == 1
    assert np.array_equal(region, s.region) and np.array_equal(guide, s.guideline)
    xb, rb, gb = make_batch(data, np.array([5, 6]), np.array([3, 6]))
    assert xb.shape == (2, 3, 201, 201) and rb.shape == gb.shape == (2, 1, 201, 201)
    # augmented sample: start pixel moved with the map
    k = 3
    assert xb[0, 1].numpy()[transform_point(s.start, k, s.map.shape)] == 1
    assert np.array_equal(xb[0, 0].numpy() > 0, transform_array(s.map, k))


def test_epoch_order_is_seeded():
    a, ka = epoch_order(50, seed=1, epoch=2)
    b, kb = epoch_order(50, seed=1, epoch=2)
    c, _ = epoch_order(50, seed=1, epoch=3)
    assert np.array_equal(a, b) and np.array_equal(ka, kb) and not np.array_equal(a, c)


#: ``NDRQL_CACHE`` as this module was collected: ``tiny_dataset`` points it at a folder of its own for the whole module.
SESSION_CACHE = os.environ.get("NDRQL_CACHE")


@pytest.fixture()
def session_cache(monkeypatch):
    """ndrql's cache as the session has it, where the real dataset is decoded once for every test (in
    ``tiny_dataset``'s folder the 12,000 training samples would be decoded again, 20-50 s, and thrown away)."""
    if SESSION_CACHE is None:
        monkeypatch.delenv("NDRQL_CACHE", raising=False)
    else:
        monkeypatch.setenv("NDRQL_CACHE", SESSION_CACHE)


@pytest.mark.slow
def test_real_split_holds_out_whole_maps_and_no_seen_map(dataset_root, session_cache):
    train = cache_mod.load_split(dataset_root, "train", progress=False)
    seen = cache_mod.load_split(dataset_root, "seen", progress=False)
    tr, va = train_val_split(train, seen, 0.05, seed=0)
    assert len(tr) + len(va) == 12000 and len(set(tr) & set(va)) == 0
    hashes = np.array(map_hashes(train.maps))
    train_maps, val_maps = set(hashes[train.map_index[tr]]), set(hashes[train.map_index[va]])
    assert not train_maps & val_maps
    assert not val_maps & set(map_hashes(seen.maps))
    assert 400 <= len(va) <= 800
