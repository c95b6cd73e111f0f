"""STDC backbone (Fan et al., 2021): Short-Term Dense Concatenate blocks, from scratch.

STDC1 = stem (32, 64) + stages of (2, 2, 2) blocks at 256, 512, 1024 channels; STDC2 = (4, 5, 3).
A width multiplier scales every channel count (the CPU default uses 0.5). Stages 3, 4, 5 come out
at strides 8, 16, 32 (docs/method.md).
"""

from __future__ import annotations

import torch
from torch import nn

from ndrql.model.layers import ConvBNReLU

#: Blocks per stage (stages 3, 4, 5) of each STDC variant.
STDC_DEPTHS: dict[str, tuple[int, int, int]] = {"stdc1": (2, 2, 2), "stdc2": (4, 5, 3)}


def scaled(channels: int, width: float, minimum: int = 8) -> int:
    """Channel count times the width multiplier, rounded to a multiple of 8."""
    return max(minimum, int(round(channels * width / 8)) * 8)


class STDCBlock(nn.Module):
    """One STDC module: 1x1 then three 3x3 convs at out/2, out/4, out/8, out/8, concatenated."""

    def __init__(self, cin: int, cout: int, stride: int):
        super().__init__()
        c2, c4, c8 = cout // 2, cout // 4, cout // 8
        self.conv0 = ConvBNReLU(cin, c2, kernel=1)
        self.down = ConvBNReLU(c2, c2, 3, stride=2, groups=c2, act=False) if stride == 2 else None
        self.skip = nn.AvgPool2d(3, 2, 1) if stride == 2 else None
        self.conv1 = ConvBNReLU(c2, c4)
        self.conv2 = ConvBNReLU(c4, c8)
        self.conv3 = ConvBNReLU(c8, cout - c2 - c4 - c8)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x0 = self.conv0(x)
        x1 = self.conv1(self.down(x0) if self.down is not None else x0)
        x2 = self.conv2(x1)
        x3 = self.conv3(x2)
        first = self.skip(x0) if self.skip is not None else x0
        return torch.cat([first, x1, x2, x3], dim=1)


class STDCBackbone(nn.Module):
    """STDC encoder returning the stage 3, 4 and 5 features (strides 8, 16, 32)."""

    def __init__(self, variant: str = "stdc1", in_channels: int = 3, width: float = 1.0):
        super().__init__()
        depths = STDC_DEPTHS[variant]
        stem1, stem2 = scaled(32, width), scaled(64, width)
        self.stem = nn.Sequential(ConvBNReLU(in_channels, stem1, stride=2), ConvBNReLU(stem1, stem2, stride=2))
        self.out_channels: tuple[int, int, int] = tuple(scaled(c, width) for c in (256, 512, 1024))  # type: ignore[assignment]
        stages, cin = [], stem2
        for depth, cout in zip(depths, self.out_channels):
            blocks = [STDCBlock(cin if i == 0 else cout, cout, stride=2 if i == 0 else 1) for i in range(depth)]
            stages.append(nn.Sequential(*blocks))
            cin = cout
        self.stages = nn.ModuleList(stages)

    def forward(self, x: torch.Tensor) -> list[torch.Tensor]:
        return run_stages(self.stem, self.stages, x)


def run_stages(stem: nn.Module, stages: nn.ModuleList, x: torch.Tensor) -> list[torch.Tensor]:
    """Apply the stem, then each stage in turn; return every stage's output (shallow to deep)."""
    x = stem(x)
    feats = []
    for stage in stages:
        x = stage(x)
        feats.append(x)
    return feats
