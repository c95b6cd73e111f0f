"""Training loss: BCE + Dice on the region and guideline outputs (docs/method.md), and for a model with
a distance head the goal-distance loss (:func:`distance_loss`)."""

from __future__ import annotations

import torch
import torch.nn.functional as F

from ndrql.dataset.render import DISTANCE_UNIT, PX_PER_CELL


def dice_loss(logits: torch.Tensor, target: torch.Tensor, eps: float = 1.0) -> torch.Tensor:
    """1 - soft Dice per image, averaged over the batch."""
    prob = torch.sigmoid(logits.float()).flatten(1)
    target = target.flatten(1)
    inter = (prob * target).sum(1)
    return (1 - (2 * inter + eps) / (prob.sum(1) + target.sum(1) + eps)).mean()


def bce_dice(logits: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Binary cross-entropy plus Dice loss."""
    return F.binary_cross_entropy_with_logits(logits.float(), target) + dice_loss(logits, target)


def ndr_loss(region_logits: torch.Tensor, guide_logits: torch.Tensor | None, region: torch.Tensor, guide: torch.Tensor,
             distance: torch.Tensor | None = None, distance_target: torch.Tensor | None = None) -> torch.Tensor:
    """Sum of BCE + Dice on the region and (when present) the guideline output, plus
    :func:`distance_loss` when the model predicts a distance and the batch has its label."""
    loss = bce_dice(region_logits, region)
    if guide_logits is not None:
        loss = loss + bce_dice(guide_logits, guide)
    if distance is not None and distance_target is not None:
        loss = loss + distance_loss(distance, distance_target, weight=1.0 + REGION_WEIGHT * region)
    return loss


#: Weight of the cell-to-cell difference term in :func:`distance_loss`.
ORDER_WEIGHT = 1.0
#: Extra weight of the distance error inside the region label (where Eq. 7's mask keeps the agent).
REGION_WEIGHT = 2.0


def distance_loss(pred: torch.Tensor, target: torch.Tensor, unit: float = DISTANCE_UNIT, px_per_cell: int = PX_PER_CELL,
                  weight: torch.Tensor | None = None) -> torch.Tensor:
    """Distance-head loss on the pixels whose target (the detour, :func:`ndrql.dataset.mixture.stack`) is
    known (``>= 0``), both in units of ``unit`` cells.

    Relative L1 ``|p - t| / (1 + t)`` (long detours may err more in absolute terms) plus
    :data:`ORDER_WEIGHT` times the L1 error, in cells, of the differences between pixels one cell apart
    (``px_per_cell``) along rows and columns: what Eq. 6 compares is neighbouring cells, so their order
    matters more than the absolute value. ``weight`` (same shape, optional) weighs the pixels of the first
    term. 0 (with a gradient) when no target is known.
    """
    pred = pred.float()
    known = target >= 0
    if not bool(known.any()):
        return pred.sum() * 0.0
    w = torch.ones_like(target) if weight is None else weight.float()
    err = (pred - target).abs() / (1.0 + target.clamp(min=0))
    loss = (err * w)[known].sum() / w[known].sum().clamp(min=1e-6)
    k = int(px_per_cell)
    for dim in (-2, -1):
        n = pred.shape[dim] - k
        if n <= 0:
            continue
        a, b = (lambda t: t.narrow(dim, 0, n)), (lambda t: t.narrow(dim, k, n))
        both = a(known) & b(known)
        if bool(both.any()):
            err = ((b(pred) - a(pred)) - (b(target) - a(target))).abs() * unit
            loss = loss + ORDER_WEIGHT * 0.5 * err[both].mean()
    return loss
