"""Test-time symmetry: turns invert, the average of an equivariant runner is the runner, counts are checked."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.model.symmetry import ORDER, averaged, digest_suffix, turn, turn_back


def test_each_turn_is_undone_and_the_eight_are_distinct():
    x = np.arange(2 * 3 * 16, dtype=np.float32).reshape(2, 3, 4, 4)
    seen = set()
    for k in range(8):
        t = turn(x, k)
        assert np.array_equal(turn_back(t, k), x)
        seen.add(t.tobytes())
    assert len(seen) == 8 and sorted(ORDER) == list(range(8))


def test_first_four_are_a_group():
    """Identity, transpose, half turn and their product: composing two stays inside the four."""
    x = np.arange(25, dtype=np.float32).reshape(5, 5)
    four = {turn(x, k).tobytes() for k in ORDER[:4]}
    assert all(turn(turn(x, a), b).tobytes() in four for a in ORDER[:4] for b in ORDER[:4])


def test_average_of_an_equivariant_runner_is_its_output_and_of_a_biased_one_is_symmetric():
    x = np.random.default_rng(0).random((2, 3, 8, 8)).astype(np.float32)
    calls = []

    def equivariant(batch):  # per-pixel: commutes with every turn
        calls.append(batch.shape[0])
        return batch[:, 0] * 2.0, None, batch[:, 1] - batch[:, 2]

    one = equivariant(x)
    for count in (2, 4, 8):
        out = averaged(equivariant, x, count)
        assert out[1] is None and calls[-1] == 2 * count  # one batch with every orientation
        np.testing.assert_allclose(out[0], one[0], rtol=1e-6)
        np.testing.assert_allclose(out[2], one[2], rtol=1e-6)
    ramp = np.broadcast_to(np.arange(8, dtype=np.float32), (8, 8))

    def biased(batch):  # adds a left-to-right ramp whatever the input: not equivariant
        return batch[:, 0] + ramp, None, None

    avg = averaged(biased, np.zeros((1, 3, 8, 8), np.float32), 8)[0][0]
    np.testing.assert_allclose(avg, avg.T, atol=1e-5)
    np.testing.assert_allclose(avg, np.rot90(avg), atol=1e-5)


@pytest.mark.parametrize("count, shape, message", [(3, (1, 3, 8, 8), "one of 1, 2, 4, 8"),
                                                   (2, (1, 3, 8, 6), "square input")])
def test_bad_counts_and_shapes_are_one_line(count, shape, message):
    with pytest.raises(ValueError, match=message):
        averaged(lambda b: (b[:, 0], None, None), np.zeros(shape, np.float32), count)


def test_predictor_averages_its_grid_prediction_over_the_turned_grid():
    """``symmetries=2``: the mean of the plain prediction and of the prediction on the transposed grid
    (start and goal transposed with it), transposed back; the network is shared, not reloaded."""
    torch = pytest.importorskip("torch")
    from ndrql.model.predict import Predictor
    from ndrql.model.registry import build_model

    torch.manual_seed(0)
    model = build_model({"arch": "ndr", "encoding": "point", "width": 0.25, "unet_base": 8, "input_mode": "grid",
                         "distance_head": True, "distance_decoder": "skips"})
    plain = Predictor.from_model(model, threads=1)
    plain.input_mode = "grid"
    blocked = np.zeros((12, 12), bool)
    blocked[4, 2:9] = True
    blocked[7:11, 6] = True
    start, goal = (1, 1), (10, 9)
    two = plain.with_symmetries(2)
    assert two.model is plain.model and two.input_mode == "grid" and plain.symmetries == 1
    a = plain.predict_grid_all(blocked, start, goal)
    b = plain.predict_grid_all(blocked.T, start[::-1], goal[::-1])
    got = two.predict_grid_all(blocked, start, goal)
    for x, y, z in zip(a, b, got):
        np.testing.assert_allclose(z, (x + y.T) / 2, atol=2e-5)
    assert np.abs(a[2] - got[2]).max() > 1e-3  # the untrained network is not symmetric: averaging changes it
    with pytest.raises(Exception, match="symmetries must be one of 1, 2, 4, 8"):
        plain.with_symmetries(3)


def test_digest_suffix_names_only_averaged_predictions():
    assert digest_suffix(1) == "" and digest_suffix(4) == "-s4" and digest_suffix(8) == "-s8"
    with pytest.raises(ValueError, match="symmetries must be one of"):
        digest_suffix(3)
