"""Output heads: the region head, the 4-level UNet guideline decoder and the goal-distance head."""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from ndrql.model.layers import ConvBNReLU


class RegionHead(nn.Module):
    """3x3 conv + 1x1 conv to one logit channel (sigmoid applied by the caller)."""

    def __init__(self, cin: int, cmid: int):
        super().__init__()
        self.conv = ConvBNReLU(cin, cmid)
        self.cls = nn.Conv2d(cmid, 1, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.cls(self.conv(x))


class DoubleConv(nn.Sequential):
    """Two 3x3 conv-BN-ReLU, the UNet level."""

    def __init__(self, cin: int, cout: int):
        super().__init__(ConvBNReLU(cin, cout), ConvBNReLU(cout, cout))


class UNetDecoder(nn.Module):
    """A 4-level UNet (Ronneberger et al.) turning region probability + map channels into a guideline.

    CPU-sized: the four levels run at strides 2, 4, 8, 16 (a strided stem conv sees every input
    pixel), then a light full-resolution refinement on the upsampled features concatenated with the
    input restores the 2 px detail. Input height and width must be divisible by 16.
    """

    def __init__(self, cin: int, base: int = 16):
        super().__init__()
        chans = [base, base * 2, base * 4, base * 8]
        self.stem = ConvBNReLU(cin, base, stride=2)
        self.down = nn.ModuleList()
        prev = base
        for c in chans:
            self.down.append(DoubleConv(prev, c))
            prev = c
        self.up = nn.ModuleList()
        for c_skip in reversed(chans[:-1]):
            self.up.append(DoubleConv(prev + c_skip, c_skip))
            prev = c_skip
        self.refine = ConvBNReLU(prev + cin, base // 2)
        self.cls = nn.Conv2d(base // 2, 1, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        inp = x
        x = self.stem(x)
        skips = []
        for i, block in enumerate(self.down):
            x = block(x if i == 0 else F.max_pool2d(x, 2))
            skips.append(x)
        for block, skip in zip(self.up, reversed(skips[:-1])):
            x = F.interpolate(x, size=skip.shape[-2:], mode="bilinear", align_corners=False)
            x = block(torch.cat([x, skip], dim=1))
        x = F.interpolate(x, size=inp.shape[-2:], mode="bilinear", align_corners=False)
        return self.cls(self.refine(torch.cat([x, inp], dim=1)))


class DistanceHead(nn.Module):
    """Each pixel's distance to the goal through free space.

    A coarse field at the fused features' stride 8 (where the pyramid pooling's global context is),
    from those features and the input channels max-pooled to that stride, through a stack of dilated
    convolutions (receptive field about 60 cells at 4 px per cell), is upsampled and corrected at full
    resolution by a light convolution that also sees the input channels (the walls).
    """

    def __init__(self, cin: int, cmid: int, in_channels: int, dilations: tuple[int, ...] = (2, 4, 8, 16), refine: int = 8):
        super().__init__()
        layers: list[nn.Module] = [ConvBNReLU(cin + in_channels, cmid)]
        for d in dilations:
            layers += [nn.Conv2d(cmid, cmid, 3, padding=d, dilation=d, bias=False), nn.BatchNorm2d(cmid), nn.ReLU(inplace=True)]
        self.coarse = nn.Sequential(*layers, nn.Conv2d(cmid, 1, 1))
        self.refine = nn.Sequential(ConvBNReLU(in_channels + 1, refine), ConvBNReLU(refine, refine), nn.Conv2d(refine, 1, 1))

    def forward(self, features: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
        """``features`` at stride 8 of ``x`` (whose sides are multiples of 8)."""
        pooled = F.max_pool2d(x, x.shape[-1] // features.shape[-1])
        coarse = self.coarse(torch.cat([features, pooled], dim=1))
        coarse = F.interpolate(coarse, size=x.shape[-2:], mode="bilinear", align_corners=False)
        return coarse + self.refine(torch.cat([coarse, x], dim=1))
