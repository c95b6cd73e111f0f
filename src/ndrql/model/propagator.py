"""The propagating head: one weight-tied block iterated over the planning grid (torch; training and export).

Where the companion, the base model, the relay and four orientations all leave a large grid without a region
(studies/large_view/history.md#a-propagating-head-where-everything-else-fails-rule-written-2026-11-27-before-its-runs),
``plan`` asks this head (through its ONNX graph, :mod:`ndrql.model.propagation`, no torch). It sees the grid
at one pixel per cell (free, start, goal) and answers, per cell, "on some 4-connected shortest route from start
to goal".

The state lives on the cells; every iteration sees the input again ("recall", as recurrent "thinking" networks
that learn to solve mazes larger than their training mazes: Schwarzschild et al. 2021, Bansal et al. 2022), and
the state and the block's intermediate layer are zeroed on blocked cells, so what it carries travels along the free
space only (never through a wall one cell thick), two cells per iteration (two 3x3 convolutions). With ``pool``
the block also sees a 3x3 max of the state, as a value-iteration network's recurrence takes the max over moves
(Tamar et al. 2016): the max is the only structure given, what is carried is learned.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import torch
from torch import nn

from ndrql.io import atomic_path
from ndrql.model.checkpoint import check_tensors
from ndrql.model.propagation import head_input

#: Iterations of the block per call of the exported graph (``plan`` runs whole calls).
CHUNK = 8


class Propagator(nn.Module):
    """The head: ``width`` state channels per cell; :meth:`forward` runs ``iters`` iterations."""

    def __init__(self, width: int = 12, pool: bool = False) -> None:
        super().__init__()
        self.width = width
        self.pool = pool
        self.c1 = nn.Conv2d(width * (2 if pool else 1) + 3, width, 3, padding=1)
        self.c2 = nn.Conv2d(width, width, 3, padding=1)
        self.h1 = nn.Conv2d(width + 3, width, 3, padding=1)
        self.h2 = nn.Conv2d(width, 1, 1)

    def init_state(self, x: torch.Tensor) -> torch.Tensor:
        return torch.zeros(x.shape[0], self.width, *x.shape[2:], dtype=x.dtype, device=x.device)

    def step(self, h: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
        """One iteration; ``x`` is ``(batch, 3, h, w)`` (free, start, goal)."""
        parts = [h, nn.functional.max_pool2d(h, 3, 1, 1), x] if self.pool else [h, x]
        z = torch.relu(self.c1(torch.cat(parts, 1))) * x[:, :1]  # masked too: nothing crosses a wall one cell thick
        return torch.tanh(h + self.c2(z)) * x[:, :1]

    def head(self, h: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
        """Per-cell logit of "on a shortest route"; -20 on blocked cells."""
        out = self.h2(torch.relu(self.h1(torch.cat([h, x], 1))))
        return out.masked_fill(x[:, :1] < 0.5, -20.0)

    def forward(self, x: torch.Tensor, iters: int, h: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        h = self.init_state(x) if h is None else h
        for _ in range(iters):
            h = self.step(h, x)
        return self.head(h, x), h


class _Chunk(nn.Module):
    """:data:`CHUNK` iterations and the head: the exported graph's body."""

    def __init__(self, net: Propagator) -> None:
        super().__init__()
        self.net = net

    def forward(self, x: torch.Tensor, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        for _ in range(CHUNK):
            h = self.net.step(h, x)
        return self.net.head(h, x), h


def load_propagator(path: str | Path) -> Propagator:
    """A head from a checkpoint written by ``studies/propagate/train.py`` (``state``, ``width``, ``pool``)."""
    ck = torch.load(path, map_location="cpu", weights_only=True)
    check_tensors(ck, path)  # shape, stride and size before anything is copied
    net = Propagator(int(ck["width"]), bool(ck.get("pool", False)))
    net.load_state_dict(ck["state"])
    return net.eval()


def export_propagator(weights: str | Path, out: str | Path) -> float:
    """Export the head of ``weights`` as an ONNX graph of :data:`CHUNK` iterations (inputs ``x`` (1, 3, h, w) and
    ``h`` (1, width, h, w); outputs ``logit`` and ``h``; any ``h, w``) to ``out``. Returns the largest |probability
    difference| from torch over 64 iterations on a random 40x52 grid (ONNX Runtime, checked here)."""
    import onnxruntime as ort

    net = load_propagator(weights)
    rng = np.random.default_rng(0)
    blocked = rng.random((40, 52)) < 0.3
    blocked[1, 1] = blocked[38, 50] = False
    x = torch.as_tensor(head_input(blocked, (1, 1), (38, 50)))  # the input plan feeds the graph
    h0 = net.init_state(x)
    with warnings.catch_warnings(), atomic_path(out) as tmp:  # the one writer (ndrql.io)
        warnings.simplefilter("ignore", DeprecationWarning)  # the TorchScript exporter handles this model
        torch.onnx.export(_Chunk(net), (x, h0), str(tmp), input_names=["x", "h"], output_names=["logit", "h_out"],
                          dynamic_axes={"x": {2: "rows", 3: "cols"}, "h": {2: "rows", 3: "cols"},
                                        "logit": {2: "rows", 3: "cols"}, "h_out": {2: "rows", 3: "cols"}},
                          opset_version=17, dynamo=False)
    with torch.no_grad():
        want = torch.sigmoid(net(x, 8 * CHUNK)[0]).numpy()
    sess = ort.InferenceSession(str(out), providers=["CPUExecutionProvider"])
    h = h0.numpy()
    for _ in range(8):
        logit, h = sess.run(None, {"x": x.numpy(), "h": h})
    return float(np.abs(1 / (1 + np.exp(-logit)) - want).max())
