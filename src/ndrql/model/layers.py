"""Small building blocks shared by the backbone, context module and decoders."""

from __future__ import annotations

import torch
from torch import nn


def exporting() -> bool:
    """True while the model is traced for ONNX export: input sizes are then symbolic, and the code
    that depends on them takes its size-generic form (same numbers as the eager form)."""
    return torch.jit.is_tracing() or torch.onnx.is_in_onnx_export()


class ConvBNReLU(nn.Sequential):
    """Conv -> BatchNorm -> ReLU, 'same' padding (the STDC paper's ConvX)."""

    def __init__(self, cin: int, cout: int, kernel: int = 3, stride: int = 1, groups: int = 1, act: bool = True):
        layers: list[nn.Module] = [
            nn.Conv2d(cin, cout, kernel, stride, kernel // 2, groups=groups, bias=False),
            nn.BatchNorm2d(cout),
        ]
        if act:
            layers.append(nn.ReLU(inplace=True))
        super().__init__(*layers)
