"""Attention fusion module (PP-LiteSeg's UAFM with spatial attention, paper's AFM).

The upsampled high-level feature and the low-level feature are mixed per pixel with a weight
``alpha`` computed from their channel means and maxima: ``out = high * alpha + low * (1 - alpha)``.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from ndrql.model.layers import ConvBNReLU


class AttentionFusion(nn.Module):
    """Fuse a coarse feature ``high`` (already at ``cout`` channels) into a finer ``low``."""

    def __init__(self, low_channels: int, high_channels: int, cout: int):
        super().__init__()
        self.low = ConvBNReLU(low_channels, high_channels)
        self.attention = nn.Sequential(ConvBNReLU(4, 2), ConvBNReLU(2, 1, act=False))
        self.out = ConvBNReLU(high_channels, cout)

    def forward(self, low: torch.Tensor, high: torch.Tensor) -> torch.Tensor:
        low = self.low(low)
        high = F.interpolate(high, size=low.shape[-2:], mode="bilinear", align_corners=False)
        stats = torch.cat(
            [high.mean(1, keepdim=True), high.amax(1, keepdim=True), low.mean(1, keepdim=True), low.amax(1, keepdim=True)],
            dim=1,
        )
        alpha = torch.sigmoid(self.attention(stats))
        return self.out(high * alpha + low * (1 - alpha))
