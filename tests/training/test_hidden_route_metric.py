"""The distance measured where a belief hides the true route (``distance_order/hidden_route``,
``detour_error/hidden_route``): the part of the goal distance NDR-QL's steps follow on belief maps."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from ndrql.dataset.render import DISTANCE_UNIT, Rendered
from ndrql.training.evaluate import evaluate_rendered, hidden_route_counts


def test_hidden_route_counts_on_known_input():
    base = np.arange(8, dtype=np.float32)[None, :]
    detour = np.zeros((1, 8), np.float32)
    pred = np.zeros((1, 8), np.float32)
    pred[0, 4] = 3.0  # pred + base: 0 1 2 3 7 5 6 7
    hidden = np.zeros((1, 8), bool)
    hidden[0, 2:7] = True
    right, pairs, error, pixels = hidden_route_counts(pred, detour, base, hidden, step=1)
    assert (right, pairs) == (3, 4)  # pairs (2,3) (3,4) (4,5) (5,6); only 7 -> 5 is out of order
    assert (error, pixels) == (3.0 * DISTANCE_UNIT, 5)  # 3 label units at one pixel, in moves
    detour[0, 4] = -1.0  # no label there: neither its pairs nor its error count
    right, pairs, error, pixels = hidden_route_counts(pred, detour, base, hidden, step=1)
    assert (right, pairs, error, pixels) == (2, 2, 0.0, 4)


class _Constant(torch.nn.Module):
    """Region and guideline logits 0 and a detour of ``value`` label units everywhere."""

    def __init__(self, value: float):
        super().__init__()
        self.value = value

    def forward(self, x):
        b, _, h, w = x.shape
        zeros = torch.zeros(b, 1, h, w)
        return zeros, zeros, torch.full((b, 1, h, w), self.value)


def _item(unknown: bool) -> Rendered:
    side = 16  # 4 cells of 4 px: an empty grid, so every detour is 0
    cells = np.arange(side) // 4
    dist = (np.abs(cells - 3)[:, None] + np.abs(cells - 3)[None, :]).astype(np.float32)
    region = np.zeros((side, side), bool)
    region[:, 8:] = True
    hide = np.zeros((side, side), bool)
    hide[4:12, :] = True
    return Rendered(np.zeros((side, side), bool), (2, 2), (14, 14), region.copy(), region, dist,
                    hide if unknown else None)


@pytest.mark.parametrize("value", [0.0, 1.0])
def test_evaluate_rendered_reports_the_hidden_route_on_belief_items(value):
    out = evaluate_rendered(_Constant(value), [("a", _item(True)), ("b", _item(False))], encoding="point+unknown")
    assert out["distance_order/hidden_route"] == 100.0  # a constant detour keeps every order
    assert out["detour_error/hidden_route"] == pytest.approx(value * DISTANCE_UNIT)


def test_known_maps_alone_report_no_hidden_route():
    out = evaluate_rendered(_Constant(0.0), [("b", _item(False))], encoding="point+unknown")
    assert "distance_order/all" in out
    assert "distance_order/hidden_route" not in out and "detour_error/hidden_route" not in out
