"""studies/propagate: the probe's target on a hand-drawn grid, and its head keeping to the free space."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import torch

HERE = Path(__file__).resolve().parents[1] / "propagate"


def _load(name: str):
    sys.path.insert(0, str(HERE))
    try:
        spec = importlib.util.spec_from_file_location(name, HERE / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod
    finally:
        sys.path.remove(str(HERE))


def test_on_route_marks_every_shortest_route_and_nothing_else():
    data = _load("data")
    # a 3x4 grid with a wall in the middle column except the top row: the only way is over the top
    blocked = np.array([[0, 0, 0, 0],
                        [0, 1, 1, 0],
                        [0, 1, 1, 0]], bool)
    route = data.on_route(blocked, (2, 0), (2, 3))
    want = np.array([[1, 1, 1, 1],
                     [1, 0, 0, 1],
                     [1, 0, 0, 1]], bool)
    assert (route == want).all()
    # open 2x2: both L-shaped routes are shortest, so all four cells
    assert data.on_route(np.zeros((2, 2), bool), (0, 0), (1, 1)).all()


def test_one_path_is_a_thin_band_inside_the_routes():
    data = _load("data")
    blocked = np.zeros((9, 9), bool)
    blocked[4, :7] = True  # a wall with its gap on the right
    s, g = (0, 0), (8, 0)
    band = data.one_path(blocked, s, g)
    assert band[s] and band[g] and not (band & blocked).any()
    from scipy import ndimage
    labels, _ = ndimage.label(band)
    assert labels[s] == labels[g]  # one piece from start to goal
    routes = data.on_route(blocked, s, g)
    # every shortest route fills the open rectangles on both sides of the gap (65 cells); the band follows one path
    assert routes.sum() == 65 and band.sum() == 47
    assert (band & routes).sum() >= 23  # the path's own cells: the 22 moves of the optimum, 23 cells


def test_the_head_carries_nothing_through_walls():
    net_mod = _load("net")
    torch.manual_seed(0)
    net = net_mod.Propagator(4)
    blocked = np.zeros((6, 6), bool)
    blocked[:, 2] = True  # a full wall: the right half cannot hear the start
    x = net_mod.inputs(blocked, (0, 0), (5, 5))[None]
    with torch.no_grad():
        _, h = net(x, 10)
    assert float(h[0, :, :, 2].abs().max()) == 0.0
    x2 = x.clone()
    x2[0, 1] = 0.0
    x2[0, 1, 5, 0] = 1.0  # the start moved, still left of the wall
    with torch.no_grad():
        _, h2 = net(x2, 10)
    left = slice(0, 2)
    assert not torch.allclose(h[0, :, :, left], h2[0, :, :, left])
    # the right half sees the same goal and free cells and nothing else, so its state is the same
    assert torch.allclose(h[0, :, :, 3:], h2[0, :, :, 3:])
