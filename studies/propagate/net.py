"""A recurrent propagating head: one weight-tied block iterated over the planning grid (probe).

The state lives on the cells; every iteration sees the input again ("recall") and is zeroed on blocked
cells, and so is its intermediate layer, so what it carries travels along the free space only (never through a wall
one cell thick), two cells per iteration (two 3x3 convs). With ``pool`` the block also sees a 3x3 max of the
state, as a value-iteration network's recurrence takes the max over moves (Tamar et al. 2016): learned
weights decide what is carried; the max lets a decaying "reached from here" signal travel without fading.
The output is a per-cell logit of "this cell is on a shortest route from start to goal".
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn


def inputs(blocked, start, goal) -> torch.Tensor:
    """``(3, h, w)`` float: free, start, goal."""
    free = torch.as_tensor(~np.asarray(blocked, bool), dtype=torch.float32)
    s = torch.zeros_like(free)
    g = torch.zeros_like(free)
    s[start] = 1.0
    g[goal] = 1.0
    return torch.stack([free, s, g])


class Propagator(nn.Module):
    def __init__(self, width: int = 12, pool: bool = False) -> None:
        super().__init__()
        self.width = width
        self.pool = pool  # a 3x3 max of the state fed to the block as well (the max over moves of value iteration)
        self.c1 = nn.Conv2d(width * (2 if pool else 1) + 3, width, 3, padding=1)
        self.c2 = nn.Conv2d(width, width, 3, padding=1)
        self.h1 = nn.Conv2d(width + 3, width, 3, padding=1)
        self.h2 = nn.Conv2d(width, 1, 1)

    def init_state(self, x: torch.Tensor) -> torch.Tensor:
        return torch.zeros(x.shape[0], self.width, *x.shape[2:], dtype=x.dtype, device=x.device)

    def step(self, h: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
        parts = [h, nn.functional.max_pool2d(h, 3, 1, 1), x] if self.pool else [h, x]
        z = torch.relu(self.c1(torch.cat(parts, 1))) * x[:, :1]  # masked too: nothing crosses a wall one cell thick
        return torch.tanh(h + self.c2(z)) * x[:, :1]

    def head(self, h: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
        out = self.h2(torch.relu(self.h1(torch.cat([h, x], 1))))
        return out.masked_fill(x[:, :1] < 0.5, -20.0)

    def forward(self, x: torch.Tensor, iters: int, h: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        h = self.init_state(x) if h is None else h
        for _ in range(iters):
            h = self.step(h, x)
        return self.head(h, x), h
