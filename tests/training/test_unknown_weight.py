"""The loss's weight on the pixels unknown to the planner (``--unknown-weight``, the belief model's fifth leg)."""

from __future__ import annotations

import math

import pytest
import torch
import torch.nn.functional as F

from ndrql.training.config import TrainConfig
from ndrql.training.losses import bce_dice, dice_loss, ndr_loss, unknown_pixel_weight


def _batch(seed: int = 0):
    g = torch.Generator().manual_seed(seed)
    logits = torch.randn(2, 1, 8, 8, generator=g)
    target = (torch.rand(2, 1, 8, 8, generator=g) > 0.5).float()
    return logits, target


def test_uniform_weights_give_the_plain_loss():
    logits, target = _batch()
    plain = bce_dice(logits, target)
    assert torch.allclose(bce_dice(logits, target, torch.full_like(target, 3.0)), plain)
    assert torch.allclose(ndr_loss(logits, logits, target, target, pixel_weight=torch.ones_like(target)),
                          ndr_loss(logits, logits, target, target))


def test_weighted_bce_is_the_hand_computed_weighted_mean():
    logits, target = _batch(1)
    w = torch.ones_like(target)
    w[:, :, :4] = 3.0  # the top half weighs three times
    per_pixel = F.binary_cross_entropy_with_logits(logits, target, reduction="none")
    top, bottom = per_pixel[:, :, :4].sum(), per_pixel[:, :, 4:].sum()
    expected = (3 * top + bottom) / (3 * 64 + 64) + dice_loss(logits, target)
    assert math.isclose(float(bce_dice(logits, target, w)), float(expected), rel_tol=1e-6)


def test_pixel_weight_reads_the_last_input_channel():
    x = torch.zeros(1, 4, 8, 8)
    x[0, 3, 2:4, 5:7] = 1.0  # unknown pixels
    x[0, 0] = 1.0            # the map channel must not count
    assert unknown_pixel_weight(x, 0.0, (8, 8)) is None
    w = unknown_pixel_weight(x, 2.0, (8, 8))
    assert w.shape == (1, 1, 8, 8)
    assert float(w.sum()) == 64 + 2.0 * 4
    assert float(w[0, 0, 2, 5]) == 3.0 and float(w[0, 0, 0, 0]) == 1.0
    half = unknown_pixel_weight(x, 2.0, (4, 4))  # labels at another shape: nearest resampling
    assert half.shape == (1, 1, 4, 4) and float(half.max()) == 3.0


def test_weight_on_unknown_pixels_moves_the_loss_toward_their_errors():
    logits, target = _batch(2)
    logits[:, :, :4] = 8 * (1 - 2 * target[:, :, :4])  # confidently wrong on the top half
    w = torch.ones_like(target)
    w[:, :, :4] = 3.0
    assert float(bce_dice(logits, target, w)) > float(bce_dice(logits, target))


@pytest.mark.parametrize("value", [-1.0, float("nan"), float("inf"), 101.0])
def test_bad_unknown_weight_is_one_clear_error(value):
    """The config checks the range the CLI declares (ndrql.limits.BOUNDS), one door for both."""
    with pytest.raises(ValueError, match=r"--unknown-weight must be a finite number in \[0, 100\]"):
        TrainConfig(encoding="point+unknown", unknown_weight=value)


def test_unknown_weight_needs_the_unknown_channel():
    with pytest.raises(ValueError, match="needs an encoding with the unknown channel"):
        TrainConfig(encoding="point", unknown_weight=2.0)
    assert TrainConfig(encoding="point+unknown", unknown_weight=2.0).unknown_weight == 2.0
