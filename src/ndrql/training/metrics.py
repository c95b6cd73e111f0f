"""F1 as the paper (and RGP) report it: threshold 0.5, pixel-wise per image, mean over a split."""

from __future__ import annotations

import numpy as np


def f1_per_image(pred: np.ndarray, label: np.ndarray) -> np.ndarray:
    """Pixel-wise F1 of boolean ``pred`` vs ``label`` for each image of a (N, H, W) stack.

    An image with no positive pixel in either gets F1 = 1 (nothing to find, nothing wrongly found).
    """
    pred = np.asarray(pred, bool).reshape(len(pred), -1)
    label = np.asarray(label, bool).reshape(len(label), -1)
    tp = (pred & label).sum(1).astype(np.float64)
    fp = (pred & ~label).sum(1)
    fn = (~pred & label).sum(1)
    denom = 2 * tp + fp + fn
    return np.where(denom > 0, 2 * tp / np.maximum(denom, 1), 1.0)


def binarize(prob: np.ndarray, threshold: float = 0.5) -> np.ndarray:
    """Probabilities to a boolean mask (``>= threshold``)."""
    return np.asarray(prob) >= threshold
