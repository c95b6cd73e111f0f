"""The NDR model (paper, Network Structure; docs/method.md).

STDC backbone -> simplified pyramid pooling on stage 5 -> two attention fusion modules (with stage 4,
then stage 3) -> region head; the region probability concatenated with the input channels feeds a
4-level UNet that predicts the guideline. Optionally (``distance_head``, beyond the paper) a third
head predicts each pixel's distance to the goal through free space, in units of
:data:`DISTANCE_UNIT` planning cells: the ordering toward the goal that Eq. 6's distance term takes
from the model instead of the straight line. Inputs of any size are padded to a multiple of 32 inside
and outputs come back at the input size, as logits (apply ``torch.sigmoid`` for probabilities).
"""

from __future__ import annotations

import contextlib
from dataclasses import asdict, dataclass, fields

import torch
import torch.nn.functional as F
from torch import nn

from ndrql.dataset.render import DISTANCE_UNIT  # noqa: F401  (re-exported: the unit of the distance output)
from ndrql.model.backbone import STDC_DEPTHS, STDCBackbone
from ndrql.model.context import SimplePyramidPooling
from ndrql.model.decoders import DistanceHead, RegionHead, SkipDistanceHead, UNetDecoder
from ndrql.model.fusion import AttentionFusion
from ndrql.model.layers import exporting


DISTANCE_DECODERS = {"coarse": DistanceHead, "skips": SkipDistanceHead}
"""The goal-distance heads by the name NDRConfig.distance_decoder gives."""


@dataclass(frozen=True)
class NDRConfig:
    """Architecture of an NDR network; saved beside the weights so checkpoints rebuild themselves."""

    arch: str = "ndr"
    """Model family name in the registry."""
    backbone: str = "stdc1"
    """STDC variant: stdc1 (paper) or stdc2."""
    width: float = 0.5
    """Channel width multiplier of the backbone (1.0 = paper's STDC1; 0.5 = CPU default)."""
    in_channels: int = 3
    """Input channels: map, start, goal (single-pixel encoding)."""
    context_channels: int = 128
    """Channels of the pyramid pooling output (PP-LiteSeg-T: 128)."""
    fusion_channels: tuple[int, int] = (96, 64)
    """Output channels of the two attention fusion modules (with stage 4, then stage 3)."""
    guideline_decoder: bool = True
    """Predict the guideline with the UNet decoder (False = region-only ablation)."""
    unet_base: int = 16
    """Channels of the UNet's first level (doubles per level, 4 levels)."""
    encoding: str = "point"
    """Input encoding of start and goal the model was trained with (see ndrql.dataset.encodings)."""
    input_mode: str = "map"
    """What the model was trained to see: map (the map resized, the paper's input) or grid (the planning grid at 4 px per cell)."""
    distance_head: bool = False
    """Also predict the distance to the goal through free space (grid mode; units of DISTANCE_UNIT cells)."""
    distance_decoder: str = "coarse"
    """The distance head: coarse (stride-8 field + full-res correction, v4) or skips (decoded with the walls at strides 4 and 2)."""
    view: str = "native"
    """How a grid-mode model sees large planning grids (ndrql.dataset.views.GridView: native, cap:PX, coarse:CELLS); the view it was trained under."""
    merged_weights: str = ""
    """Companion weights serving the grids the view merges: a file stem beside this file (ndrql.model.companion); empty = none."""

    @classmethod
    def from_dict(cls, data: dict) -> "NDRConfig":
        """Rebuild from ``asdict`` output (tuples come back from lists)."""
        known = {f.name for f in fields(cls)}
        unknown = set(data) - known
        if unknown:
            raise ValueError(f"unknown config fields: {sorted(unknown)}")
        kwargs = dict(data)
        if "fusion_channels" in kwargs:
            kwargs["fusion_channels"] = tuple(kwargs["fusion_channels"])
        return cls(**kwargs)

    def to_dict(self) -> dict:
        """Plain-types dictionary (safe for ``torch.load(weights_only=True)``)."""
        d = asdict(self)
        d["fusion_channels"] = list(self.fusion_channels)
        return d


def pad_to_multiple(x: torch.Tensor, multiple: int = 32) -> tuple[torch.Tensor, tuple[int, int]]:
    """Zero-pad bottom/right so H and W are multiples of ``multiple``; return the original size.

    While exporting the pad is always drawn (sizes are symbolic then; a zero pad changes nothing)."""
    h, w = x.shape[-2:]
    ph, pw = (-h) % multiple, (-w) % multiple
    if exporting() or ph or pw:
        x = F.pad(x, (0, pw, 0, ph))
    return x, (h, w)


def _full_precision(x: torch.Tensor):
    """Autocast off inside the block (the distance output needs fp32's resolution: 1/16 apart at 20)."""
    if exporting() or not torch.is_autocast_enabled(x.device.type):
        return contextlib.nullcontext()
    return torch.autocast(device_type=x.device.type, enabled=False)


class NDRNet(nn.Module):
    """NDR network: ``forward(x: (B, C, H, W)) -> (region_logits, guideline_logits)``, each (B, 1, H, W),
    plus the goal distance (B, 1, H, W) as a third output when ``distance_head``.

    With ``guideline_decoder=False`` the guideline output is ``None``.
    """

    def __init__(self, config: NDRConfig = NDRConfig()):
        super().__init__()
        if config.backbone not in STDC_DEPTHS:
            raise ValueError(f"unknown backbone {config.backbone!r}; valid: {', '.join(STDC_DEPTHS)}")
        self.config = config
        self.backbone = STDCBackbone(config.backbone, config.in_channels, config.width)
        c3, c4, c5 = self.backbone.out_channels
        f4, f3 = config.fusion_channels
        self.context = SimplePyramidPooling(c5, config.context_channels, config.context_channels)
        self.fuse4 = AttentionFusion(c4, config.context_channels, f4)
        self.fuse3 = AttentionFusion(c3, f4, f3)
        self.region_head = RegionHead(f3, f3)
        self.guideline = UNetDecoder(config.in_channels + 1, config.unet_base) if config.guideline_decoder else None
        if config.distance_decoder not in DISTANCE_DECODERS:
            raise ValueError(f"unknown distance_decoder {config.distance_decoder!r}; valid: {', '.join(DISTANCE_DECODERS)}")
        head = DISTANCE_DECODERS[config.distance_decoder]
        self.distance = head(f3, f3, config.in_channels) if config.distance_head else None

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor | None, ...]:
        if x.ndim != 4 or x.shape[1] != self.config.in_channels:
            raise ValueError(
                f"expected input (B, {self.config.in_channels}, H, W), got {tuple(x.shape)}; "
                "build inputs with ndrql.dataset.encodings.encode_input"
            )
        xp, (h, w) = pad_to_multiple(x)
        s3, s4, s5 = self.backbone(xp)
        y = self.fuse3(s3, self.fuse4(s4, self.context(s5)))
        region = F.interpolate(self.region_head(y), size=xp.shape[-2:], mode="bilinear", align_corners=False)
        guide = None
        if self.guideline is not None:
            guide = self.guideline(torch.cat([torch.sigmoid(region), xp], dim=1))[..., :h, :w]
        if self.distance is None:
            return region[..., :h, :w], guide
        with _full_precision(x):
            dist = self.distance(y.float(), xp.float(), torch.sigmoid(region.float()))[..., :h, :w]
        return region[..., :h, :w], guide, dist
