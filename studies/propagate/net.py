"""The recurrent propagating head of the probe: its one home is :mod:`ndrql.model.propagator` (shipped since
2026-11-27); ``inputs`` gives one grid's input as a torch tensor for the training script."""

from __future__ import annotations

import torch

from ndrql.model.propagation import head_input
from ndrql.model.propagator import Propagator

__all__ = ["Propagator", "inputs"]


def inputs(blocked, start, goal) -> torch.Tensor:
    """``(3, h, w)`` float: free, start, goal."""
    return torch.as_tensor(head_input(blocked, tuple(start), tuple(goal))[0])
