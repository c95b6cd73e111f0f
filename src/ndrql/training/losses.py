"""Training loss: BCE + Dice on each output (docs/method.md)."""

from __future__ import annotations

import torch
import torch.nn.functional as F


def dice_loss(logits: torch.Tensor, target: torch.Tensor, eps: float = 1.0) -> torch.Tensor:
    """1 - soft Dice per image, averaged over the batch."""
    prob = torch.sigmoid(logits.float()).flatten(1)
    target = target.flatten(1)
    inter = (prob * target).sum(1)
    return (1 - (2 * inter + eps) / (prob.sum(1) + target.sum(1) + eps)).mean()


def bce_dice(logits: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Binary cross-entropy plus Dice loss."""
    return F.binary_cross_entropy_with_logits(logits.float(), target) + dice_loss(logits, target)


def ndr_loss(region_logits: torch.Tensor, guide_logits: torch.Tensor | None, region: torch.Tensor, guide: torch.Tensor) -> torch.Tensor:
    """Sum of BCE + Dice on the region and (when present) the guideline output."""
    loss = bce_dice(region_logits, region)
    if guide_logits is not None:
        loss = loss + bce_dice(guide_logits, guide)
    return loss
