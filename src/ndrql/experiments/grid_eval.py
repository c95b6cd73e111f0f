"""F1 of a ``grid``-mode model on the paper's splits, scored two ways.

A grid-mode model never sees the 201 px map: it sees the safe planning grid of ``n`` cells (50 for
the paper's setting) at 4 px per cell and predicts there (``studies/history.md#ceiling``). So its F1 on
the paper's test splits is measured

- against the **dataset's labels** at 201 px: each map pixel takes the mean probability of its
  planning cell (exact 4x4 means), thresholded at 0.5, as the planner uses it; comparable with the
  paper model's F1, though a 4.02 px cell can never draw the dataset's 2 px guideline exactly;
- against the **grid's labels**: an 8-connected shortest path of the planning grid with shortcuts, drawn like the dataset's labels
  (the oracle arrays; what the model was trained to predict).

A sample whose start and goal do not connect on the grid of ``n`` cells is rendered at the next size of
``--size auto``'s ladder that connects them (up to ``2n``), as ``ndrql plan`` would choose.

:func:`evaluate_oracle` scores the **oracle's arrays** the same two ways (``ndrql eval --prior-from
oracle``): the grid's own labels themselves, i.e. what a perfect grid-mode model would predict. Against
the dataset's labels that is the best F1 a prediction on the planning grid can reach; against the grid's
labels it is 100 by construction.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import torch

from ndrql.dataset.batches import make_batch
from ndrql.dataset.cache import SplitArrays
from ndrql.dataset.mixture import stack
from ndrql.dataset.render import Rendered, render_grid
from ndrql.model.symmetry import averaged
from ndrql.dataset.render import to_map_pixels
from ndrql.experiments.ceiling import larger_sizes
from ndrql.training.evaluate import EvalResult, predict_batch
from ndrql.training.metrics import f1_per_image

Point = tuple[int, int]


@dataclass(frozen=True)
class GridEval:
    """Per-image F1 of a grid-mode model: against the dataset's labels (``dataset``) and the grid's own."""

    dataset: EvalResult
    grid_region_f1: np.ndarray
    grid_guideline_f1: np.ndarray
    sizes: np.ndarray
    """The planning grid each sample was rendered at (``n`` or a larger ladder size)."""


def render_at(obstacles: np.ndarray, start: Point, goal: Point, n: int) -> tuple[Rendered, int] | None:
    """The grid-mode input of one map at ``n`` cells, or at the first larger ladder size that connects."""
    for size in (n, *larger_sizes(n)):
        r = render_grid(obstacles, start, goal, size)
        if r is not None:
            return r, size
    return None


#: Region and guideline probabilities ``(B, H, W)`` (guideline ``None`` for a region-only model) from a batch's
#: input, region labels and guideline labels (torch tensors ``(B, C, H, W)``).
PredictFn = Callable[..., tuple[np.ndarray, np.ndarray | None]]


def evaluate_grid_model(model, data: SplitArrays, indices: np.ndarray, n: int = 50, encoding: str = "point",
                        batch_size: int = 16, progress: bool = False, symmetries: int = 1) -> GridEval:
    """F1 of grid-mode ``model`` on samples ``indices`` of ``data`` (module docstring); a sample that does
    not connect even at ``2n`` scores 0 everywhere. ``symmetries``: the predictions averaged over that many
    orientations of the grid, as ``ndrql plan`` does (:func:`ndrql.model.symmetry.averaged`)."""
    model.eval()

    def runner(a: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        return predict_batch(model, torch.from_numpy(np.ascontiguousarray(a)), False)

    return _evaluate(lambda x, region, guide: averaged(runner, x.numpy(), symmetries), data, indices, n, encoding,
                     batch_size, progress)


def evaluate_oracle(data: SplitArrays, indices: np.ndarray, n: int = 50, batch_size: int = 16,
                    progress: bool = False) -> GridEval:
    """F1 of the oracle's arrays (the grid's own labels, module docstring) on samples ``indices`` of ``data``,
    scored as :func:`evaluate_grid_model` scores a model (no model runs: ``images_per_s`` means nothing)."""
    return _evaluate(lambda x, region, guide: (region[:, 0].numpy(), guide[:, 0].numpy()), data, indices, n, "point",
                     batch_size, progress)


def _evaluate(predict: PredictFn, data: SplitArrays, indices: np.ndarray, n: int, encoding: str, batch_size: int,
              progress: bool) -> GridEval:
    """Per-image F1 of ``predict``'s arrays against the dataset's labels and the grid's own (module docstring)."""
    import time

    from tqdm import tqdm

    idx = np.asarray(indices)
    k = len(idx)
    rf, gf, ro = np.zeros(k), np.full(k, np.nan), np.zeros(k)
    grf, ggf, sizes = np.zeros(k), np.full(k, np.nan), np.zeros(k, int)
    rendered: dict[int, tuple[Rendered, int]] = {}
    for j, i in enumerate(tqdm(idx, desc=f"render {data.split}", disable=not progress, unit="map")):
        sr, sc, gr, gc = (int(v) for v in data.points[i])
        out = render_at(data.obstacles(i), (sr, sc), (gr, gc), n)
        if out is not None:
            rendered[j] = out
            sizes[j] = out[1]
    by_side: dict[int, list[int]] = {}
    for j, (r, _) in rendered.items():
        by_side.setdefault(r.obstacles.shape[0], []).append(j)
    infer = 0.0
    for side in sorted(by_side):
        js = by_side[side]
        for s in range(0, len(js), batch_size):
            sel = js[s:s + batch_size]
            x, region, guide = stack([rendered[j][0] for j in sel], encoding)
            t0 = time.perf_counter()
            pr, pg = predict(x, region, guide)
            infer += time.perf_counter() - t0
            grf[sel] = f1_per_image(pr >= 0.5, region[:, 0].numpy() > 0.5)
            if pg is not None:
                ggf[sel] = f1_per_image(pg >= 0.5, guide[:, 0].numpy() > 0.5)
            _, d_region, d_guide = make_batch(data, idx[sel], encoding=encoding)
            _, o_region, _ = make_batch(data, idx[sel], encoding=encoding, original_region=True)
            shape = tuple(d_region.shape[-2:])
            for t, j in enumerate(sel):
                size = rendered[j][1]
                rmap = to_map_pixels(pr[t], shape, size) >= 0.5
                rf[j] = f1_per_image(rmap[None], d_region[t:t + 1, 0].numpy() > 0.5)[0]
                ro[j] = f1_per_image(rmap[None], o_region[t:t + 1, 0].numpy() > 0.5)[0]
                if pg is not None:
                    gmap = to_map_pixels(pg[t], shape, size) >= 0.5
                    gf[j] = f1_per_image(gmap[None], d_guide[t:t + 1, 0].numpy() > 0.5)[0]
    missing = [j for j in range(k) if j not in rendered]
    if missing and np.isfinite(gf).any():
        gf[missing] = ggf[missing] = 0.0
    dataset = EvalResult(region_f1=rf, guideline_f1=gf, region_f1_original=ro, category=data.category[idx],
                         images_per_s=len(rendered) / max(infer, 1e-9))
    return GridEval(dataset, grf, ggf, sizes)
