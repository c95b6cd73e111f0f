"""Simplified pyramid pooling (paper, Network Structure): three scales (1, 2, 4), summed.

Unlike PSPNet's PPM there is no fourth scale and no concatenation with the input feature.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from ndrql.model.layers import ConvBNReLU


def adaptive_mean(x: torch.Tensor, bins: int) -> torch.Tensor:
    """``F.adaptive_avg_pool2d(x, bins)`` written with static slices (same bin edges, same values).

    Used while exporting: ONNX has no adaptive pooling for sizes that do not divide evenly.
    """
    h, w = int(x.shape[-2]), int(x.shape[-1])
    rows = []
    for i in range(bins):
        r0, r1 = (i * h) // bins, -((-(i + 1) * h) // bins)
        cols = []
        for j in range(bins):
            c0, c1 = (j * w) // bins, -((-(j + 1) * w) // bins)
            cols.append(x[..., r0:r1, c0:c1].mean(dim=(-2, -1), keepdim=True))
        rows.append(torch.cat(cols, dim=-1))
    return torch.cat(rows, dim=-2)


class SimplePyramidPooling(nn.Module):
    """Pool at each scale, 1x1 conv, upsample, sum, then a 3x3 conv."""

    def __init__(self, cin: int, cmid: int, cout: int, scales: tuple[int, ...] = (1, 2, 4)):
        super().__init__()
        self.scales = tuple(scales)
        self.branches = nn.ModuleList(
            nn.Sequential(nn.AdaptiveAvgPool2d(s), ConvBNReLU(cin, cmid, kernel=1)) for s in scales
        )
        self.out = ConvBNReLU(cmid, cout)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        size = x.shape[-2:]
        total = None
        exporting = torch.jit.is_tracing() or torch.onnx.is_in_onnx_export()
        for bins, branch in zip(self.scales, self.branches):
            pooled = adaptive_mean(x, bins) if exporting else branch[0](x)
            y = F.interpolate(branch[1](pooled), size=size, mode="bilinear", align_corners=False)
            total = y if total is None else total + y
        return self.out(total)
