"""Output heads: the region head, the 4-level UNet guideline decoder and the goal-distance heads."""

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

    def forward(self, features: torch.Tensor, x: torch.Tensor, region: torch.Tensor | None = None) -> torch.Tensor:
        """``features`` at stride 8 of ``x`` (whose sides are multiples of 8); ``region`` is not used here
        (the heads share one signature)."""
        pooled = F.max_pool2d(x, x.shape[-1] // features.shape[-1])
        coarse = self.coarse(torch.cat([features, pooled], dim=1))
        coarse = F.interpolate(coarse, size=x.shape[-2:], mode="bilinear", align_corners=False)
        return coarse + self.refine(torch.cat([coarse, x], dim=1))


class SkipDistanceHead(DistanceHead):
    """:class:`DistanceHead`'s coarse field, decoded with skips from the walls at strides 4 and 2.

    The coarse stride-8 path (same layers and names as :class:`DistanceHead`, so it warm-starts from
    one) sees far but blurs the cell right behind a wall, where the order of two neighbours flips. A
    light encoder of the input channels and the region probability at strides 2 and 4 (4 px per cell:
    stride 4 is one planning cell) meets the coarse features on the way up; at stride 4 dilated
    convolutions (1, 2, 4 cells) spread the correction along the walls. The output is the upsampled
    coarse field plus that correction.
    """

    def __init__(self, cin: int, cmid: int, in_channels: int, base: int = 16):
        super().__init__(cin, cmid, in_channels)
        del self.refine
        c2, c4 = base, 2 * base
        self.enc2 = ConvBNReLU(in_channels + 1, c2, stride=2)
        self.enc4 = nn.Sequential(ConvBNReLU(c2, c4, stride=2), ConvBNReLU(c4, c4))
        up4: list[nn.Module] = [ConvBNReLU(cmid + 1 + c4, c4)]
        for d in (1, 2, 4):
            up4 += [nn.Conv2d(c4, c4, 3, padding=d, dilation=d, bias=False), nn.BatchNorm2d(c4), nn.ReLU(inplace=True)]
        self.up4 = nn.Sequential(*up4)
        self.up2 = DoubleConv(c4 + c2, c2)
        self.out = nn.Sequential(ConvBNReLU(c2 + in_channels, base // 2), nn.Conv2d(base // 2, 1, 1))

    def forward(self, features: torch.Tensor, x: torch.Tensor, region: torch.Tensor | None = None) -> torch.Tensor:
        """``features`` at stride 8 of ``x`` (sides multiples of 8); ``region`` the region probability (B, 1, H, W)."""
        pooled = F.max_pool2d(x, x.shape[-1] // features.shape[-1])
        hidden = self.coarse[:-1](torch.cat([features, pooled], dim=1))
        coarse = self.coarse[-1](hidden)
        e2 = self.enc2(torch.cat([x, torch.zeros_like(x[:, :1]) if region is None else region], dim=1))
        e4 = self.enc4(e2)
        up = lambda t, ref: F.interpolate(t, size=ref.shape[-2:], mode="bilinear", align_corners=False)  # noqa: E731
        y = self.up4(torch.cat([up(hidden, e4), up(coarse, e4), e4], dim=1))
        y = self.up2(torch.cat([up(y, e2), e2], dim=1))
        return up(coarse, x) + self.out(torch.cat([up(y, x), x], dim=1))
