"""Simplified pyramid pooling (paper, Network Structure): three scales (1, 2, 4), summed.

Unlike PSPNet's PPM there is no fourth scale and no concatenation with the input feature.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from ndrql.model.layers import ConvBNReLU


class SimplePyramidPooling(nn.Module):
    """Pool at each scale, 1x1 conv, upsample, sum, then a 3x3 conv."""

    def __init__(self, cin: int, cmid: int, cout: int, scales: tuple[int, ...] = (1, 2, 4)):
        super().__init__()
        self.branches = nn.ModuleList(
            nn.Sequential(nn.AdaptiveAvgPool2d(s), ConvBNReLU(cin, cmid, kernel=1)) for s in scales
        )
        self.out = ConvBNReLU(cmid, cout)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        size = x.shape[-2:]
        total = None
        for branch in self.branches:
            y = F.interpolate(branch(x), size=size, mode="bilinear", align_corners=False)
            total = y if total is None else total + y
        return self.out(total)
