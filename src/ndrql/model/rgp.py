"""RGP-style peer model for the paper's Table 1 (Huang et al., 2024, as described in the NDR-QL paper).

RGB-mixed 3-channel input (map in grey, start red, goal blue), a ResNet-18-style encoder, and two
separate decoders, one for the region and one for the guideline. Written from that description, not
from RGP's code (not available offline); the width multiplier lets it match the NDR model's budget.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import torch
import torch.nn.functional as F
from torch import nn

from ndrql.model.backbone import run_stages, scaled
from ndrql.model.layers import ConvBNReLU
from ndrql.model.ndr import pad_to_multiple


@dataclass(frozen=True)
class RGPConfig:
    """Architecture of the RGP-style baseline."""

    arch: str = "rgp"
    """Model family name in the registry."""
    width: float = 0.5
    """Channel multiplier of the ResNet-18 encoder (1.0 = 64..512 channels)."""
    in_channels: int = 3
    """RGB-mixed input."""
    decoder_channels: int = 32
    """Channels of each decoder's top level."""
    encoding: str = "rgb"
    """Input encoding (ndrql.dataset.encodings)."""

    @classmethod
    def from_dict(cls, data: dict) -> "RGPConfig":
        """Rebuild from ``asdict`` output."""
        known = {f.name for f in fields(cls)}
        if set(data) - known:
            raise ValueError(f"unknown config fields: {sorted(set(data) - known)}")
        return cls(**data)

    def to_dict(self) -> dict:
        """Plain-types dictionary."""
        return asdict(self)


class BasicBlock(nn.Module):
    """ResNet basic block (two 3x3 convs with identity or projection shortcut)."""

    def __init__(self, cin: int, cout: int, stride: int):
        super().__init__()
        self.conv1 = ConvBNReLU(cin, cout, stride=stride)
        self.conv2 = ConvBNReLU(cout, cout, act=False)
        self.short = ConvBNReLU(cin, cout, kernel=1, stride=stride, act=False) if stride != 1 or cin != cout else nn.Identity()

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return F.relu(self.conv2(self.conv1(x)) + self.short(x))


class ResNet18Encoder(nn.Module):
    """ResNet-18 layout: stem (stride 4) then 4 stages of 2 blocks; features at strides 4, 8, 16, 32."""

    def __init__(self, cin: int, width: float):
        super().__init__()
        chans = [scaled(c, width) for c in (64, 128, 256, 512)]
        self.stem = nn.Sequential(ConvBNReLU(cin, chans[0], kernel=7, stride=2), nn.MaxPool2d(3, 2, 1))
        stages, prev = [], chans[0]
        for i, c in enumerate(chans):
            stages.append(nn.Sequential(BasicBlock(prev, c, 1 if i == 0 else 2), BasicBlock(c, c, 1)))
            prev = c
        self.stages = nn.ModuleList(stages)
        self.out_channels = chans

    def forward(self, x: torch.Tensor) -> list[torch.Tensor]:
        return run_stages(self.stem, self.stages, x)


class SkipDecoder(nn.Module):
    """Upsampling decoder with skip connections from the encoder, to one logit at full resolution."""

    def __init__(self, enc_channels: list[int], top: int):
        super().__init__()
        chans = [max(8, top // 2 ** i) for i in range(len(enc_channels))][::-1]  # deepest first, narrowing
        self.lateral = nn.ModuleList(ConvBNReLU(c, d, kernel=1) for c, d in zip(enc_channels[::-1], chans))
        self.blend = nn.ModuleList(ConvBNReLU(chans[i] + chans[i + 1], chans[i + 1]) for i in range(len(chans) - 1))
        self.head = nn.Sequential(ConvBNReLU(chans[-1], chans[-1]), nn.Conv2d(chans[-1], 1, 1))

    def forward(self, feats: list[torch.Tensor], size: tuple[int, int]) -> torch.Tensor:
        feats = feats[::-1]
        x = self.lateral[0](feats[0])
        for lat, blend, f in zip(self.lateral[1:], self.blend, feats[1:]):
            skip = lat(f)
            x = F.interpolate(x, size=skip.shape[-2:], mode="bilinear", align_corners=False)
            x = blend(torch.cat([x, skip], dim=1))
        return F.interpolate(self.head(x), size=size, mode="bilinear", align_corners=False)


class RGPNet(nn.Module):
    """RGP-style network: ``forward(x) -> (region_logits, guideline_logits)`` at the input size."""

    def __init__(self, config: RGPConfig = RGPConfig()):
        super().__init__()
        self.config = config
        self.encoder = ResNet18Encoder(config.in_channels, config.width)
        self.region = SkipDecoder(self.encoder.out_channels, config.decoder_channels)
        self.guideline = SkipDecoder(self.encoder.out_channels, config.decoder_channels)

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        if x.ndim != 4 or x.shape[1] != self.config.in_channels:
            raise ValueError(f"expected input (B, {self.config.in_channels}, H, W), got {tuple(x.shape)}")
        xp, (h, w) = pad_to_multiple(x)
        feats = self.encoder(xp)
        size = xp.shape[-2:]
        return self.region(feats, size)[..., :h, :w], self.guideline(feats, size)[..., :h, :w]
