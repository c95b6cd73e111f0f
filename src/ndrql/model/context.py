"""Simplified pyramid pooling (paper, Network Structure): three scales (1, 2, 4), summed.

Unlike PSPNet's PPM there is no fourth scale and no concatenation with the input feature.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from ndrql.model.layers import ConvBNReLU, exporting


def bin_matrix(n: torch.Tensor | int, bins: int, dtype: torch.dtype) -> torch.Tensor:
    """``(bins, n)`` averaging weights of adaptive pooling along one axis of length ``n``: row ``i``
    is ``1 / count`` over ``[floor(i n / bins), ceil((i + 1) n / bins))``, zero elsewhere (the bin
    edges of ``F.adaptive_avg_pool2d``). Built from ``n`` with tensor ops, so a traced ``n`` stays symbolic."""
    n = torch.as_tensor(n)
    k = torch.arange(n).unsqueeze(0)
    i = torch.arange(bins).unsqueeze(1)
    lo = torch.div(i * n, bins, rounding_mode="floor")
    hi = -torch.div(-(i + 1) * n, bins, rounding_mode="floor")
    inside = ((k >= lo) & (k < hi)).to(dtype)
    return inside / inside.sum(1, keepdim=True)


def adaptive_mean(x: torch.Tensor, bins: int) -> torch.Tensor:
    """``F.adaptive_avg_pool2d(x, bins)`` as two products with :func:`bin_matrix` (same bin edges, same
    values to rounding), for any input size.

    Used while exporting: ONNX has no adaptive pooling, and this form keeps height and width symbolic,
    so one exported graph serves every input side.
    """
    rows = bin_matrix(x.shape[-2], bins, x.dtype)
    cols = bin_matrix(x.shape[-1], bins, x.dtype)
    return torch.matmul(torch.matmul(rows, x), cols.transpose(0, 1))


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
        symbolic = exporting()
        for bins, branch in zip(self.scales, self.branches):
            pooled = adaptive_mean(x, bins) if symbolic else branch[0](x)
            y = F.interpolate(branch[1](pooled), size=size, mode="bilinear", align_corners=False)
            total = y if total is None else total + y
        return self.out(total)
