"""Evaluation of a model on a cached split: per-image region and guideline F1 (docs/method.md)."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import torch

from ndrql.dataset.batches import make_batch
from ndrql.dataset.cache import SplitArrays
from ndrql.dataset.render import DISTANCE_UNIT
from ndrql.planning.priors import snap_detour
from ndrql.training.metrics import f1_per_image


@dataclass(frozen=True)
class EvalResult:
    """Per-image F1 arrays (NaN guideline F1 for region-only models) and throughput."""

    region_f1: np.ndarray
    guideline_f1: np.ndarray
    region_f1_original: np.ndarray
    category: np.ndarray
    images_per_s: float

    def summary(self) -> dict[str, float]:
        """Mean F1 in percent."""
        return {
            "region_f1": float(100 * self.region_f1.mean()),
            "guideline_f1": float(100 * np.nanmean(self.guideline_f1)) if np.isfinite(self.guideline_f1).any() else float("nan"),
            "region_f1_original": float(100 * self.region_f1_original.mean()),
        }


def predict_batch(model: torch.nn.Module, x: torch.Tensor, bf16: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """Region and guideline probabilities (numpy, (B, H, W)) for an input batch."""
    return predict_all(model, x, bf16)[:2]


def predict_all(model: torch.nn.Module, x: torch.Tensor, bf16: bool = False) -> tuple[np.ndarray | None, ...]:
    """:func:`predict_batch` plus the goal-distance output (numpy (B, H, W), or ``None`` without that head)."""
    with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
        region, guide, *dist = model(x.contiguous(memory_format=torch.channels_last))
    r = torch.sigmoid(region.float())[:, 0].numpy()
    g = torch.sigmoid(guide.float())[:, 0].numpy() if guide is not None else None
    return r, g, (dist[0].float()[:, 0].numpy() if dist else None)


def order_accuracy(pred: np.ndarray, target: np.ndarray, step: int = 4) -> tuple[int, int]:
    """Pairs of known pixels one cell (``step`` px) apart along rows and columns whose predicted distances
    are ordered as their targets (targets of 4-connected neighbours always differ): (right, total)."""
    right = total = 0
    for axis in (-2, -1):
        n = pred.shape[axis] - step
        if n <= 0:
            continue
        a = [np.take(v, np.arange(n), axis=axis) for v in (pred, target)]
        b = [np.take(v, np.arange(step, step + n), axis=axis) for v in (pred, target)]
        both = (a[1] >= 0) & (b[1] >= 0) & (a[1] != b[1])
        right += int((np.sign(b[0] - a[0]) == np.sign(b[1] - a[1]))[both].sum())
        total += int(both.sum())
    return right, total


def hidden_route_counts(pred: np.ndarray, detour: np.ndarray, base: np.ndarray, hidden: np.ndarray,
                        step: int = 4) -> tuple[int, int, float, int]:
    """The goal distance where a belief map's planner cannot see and the true route runs (``hidden``: unknown
    pixels inside the route's region label): neighbour pairs both there ordered right (:func:`order_accuracy` of
    ``pred + base`` against ``detour + base``), and the summed absolute detour error there in moves, with the
    pixels counted: ``(right, pairs, error, pixels)``. ``pred``, ``detour`` and ``base`` are the distance head's
    output and label in its units (:func:`ndrql.dataset.mixture.distance_target`; ``detour`` -1: no label). On
    belief maps NDR-QL's steps follow this part of the distance (studies/partial/README.md, "What the distance
    measures say")."""
    hid = np.asarray(hidden, dtype=bool) & (detour >= 0)
    truth = np.where(hid, detour + base, -1.0)
    right, pairs = order_accuracy(pred + base, truth, step)
    error = float(np.abs(pred - detour)[hid].sum()) * DISTANCE_UNIT
    return right, pairs, error, int(hid.sum())


def evaluate(model: torch.nn.Module, data: SplitArrays, indices: np.ndarray | None = None, batch_size: int = 32, encoding: str = "point", bf16: bool = False, progress: bool = False) -> EvalResult:
    """F1 of ``model`` on ``data`` (all samples, or ``indices``), threshold 0.5."""
    from tqdm import tqdm

    model.eval()
    idx = np.arange(len(data)) if indices is None else np.asarray(indices)
    rf, gf, ro = [], [], []
    t0 = time.perf_counter()
    infer_time = 0.0
    for s in tqdm(range(0, len(idx), batch_size), desc=f"eval {data.split}", disable=not progress, unit="batch"):
        sel = idx[s:s + batch_size]
        x, region, guide = make_batch(data, sel, encoding=encoding)
        t1 = time.perf_counter()
        r, g = predict_batch(model, x, bf16)
        infer_time += time.perf_counter() - t1
        rf.append(f1_per_image(r >= 0.5, region[:, 0].numpy() > 0.5))
        gf.append(f1_per_image(g >= 0.5, guide[:, 0].numpy() > 0.5) if g is not None else np.full(len(sel), np.nan))
        _, region_o, _ = make_batch(data, sel, encoding=encoding, original_region=True)
        ro.append(f1_per_image(r >= 0.5, region_o[:, 0].numpy() > 0.5))
    del t0
    return EvalResult(
        region_f1=np.concatenate(rf),
        guideline_f1=np.concatenate(gf),
        region_f1_original=np.concatenate(ro),
        category=data.category[idx],
        images_per_s=len(idx) / max(infer_time, 1e-9),
    )


def category_rows(result: EvalResult, names: tuple[str, ...],
                  grid: tuple[np.ndarray, np.ndarray] | None = None) -> list[dict[str, float | str | int]]:
    """Mean F1 (percent) overall and per category; ``grid``: per-image region and guideline F1 against
    the planning grid's own labels (grid-mode models), added as two more columns."""
    rows: list[dict[str, float | str | int]] = []
    groups = [("all", np.ones(len(result.category), bool))] + [(n, result.category == i) for i, n in enumerate(names)]
    for name, sel in groups:
        if not sel.any():
            continue
        g = result.guideline_f1[sel]
        rows.append({
            "category": name,
            "n": int(sel.sum()),
            "region_f1": float(100 * result.region_f1[sel].mean()),
            "guideline_f1": float(100 * np.nanmean(g)) if np.isfinite(g).any() else float("nan"),
            "region_f1_original": float(100 * result.region_f1_original[sel].mean()),
        })
        if grid is not None:
            gg = grid[1][sel]
            rows[-1]["grid_region_f1"] = float(100 * grid[0][sel].mean())
            rows[-1]["grid_guideline_f1"] = float(100 * np.nanmean(gg)) if np.isfinite(gg).any() else float("nan")
    return rows


def markdown_table(rows: list[dict], split: str, original_labels: bool) -> str:
    """Markdown table of :func:`category_rows` (with the original-label column for UNSEEN)."""
    grid = bool(rows) and "grid_region_f1" in rows[0]
    head = "| category | n | region F1 | guideline F1 |" + (" region F1 (original labels) |" if original_labels else "")
    head += " region F1 (grid labels) | guideline F1 (grid labels) |" if grid else ""
    sep = "|---|---:|---:|---:|" + ("---:|" if original_labels else "") + ("---:|---:|" if grid else "")
    lines = [f"**{split}**", "", head, sep]
    for r in rows:
        line = f"| {r['category']} | {r['n']} | {r['region_f1']:.2f} | {r['guideline_f1']:.2f} |"
        if original_labels:
            line += f" {r['region_f1_original']:.2f} |"
        if grid:
            line += f" {r['grid_region_f1']:.2f} | {r['grid_guideline_f1']:.2f} |"
        lines.append(line)
    return "\n".join(lines) + "\n"


def evaluate_rendered(model: torch.nn.Module, items: list, encoding: str = "point", bf16: bool = False,
                      batch_size: int = 16) -> dict[str, float]:
    """Mean region and guideline F1 (percent) on rendered inputs (``(group, Rendered)`` pairs, any sides),
    overall and per group (``region_f1/<group>``); for a model with a distance head also the percentage of
    neighbouring cells whose goal distances it orders right (``distance_order/all``, :func:`order_accuracy`),
    raw and with the detour snapped as Eq. 6 takes it (``distance_order_snapped/all``,
    :func:`ndrql.planning.priors.snap_detour`), and on the belief maps among ``items`` the same order and the
    mean absolute detour error in moves where the belief hides the true route (``distance_order/hidden_route``,
    ``detour_error/hidden_route``, :func:`hidden_route_counts`)."""
    from ndrql.dataset.mixture import stack  # lazy: loads scipy

    model.eval()
    rf: list[float] = []
    gf: list[float] = []
    groups: list[str] = []
    by_side: dict[int, list[int]] = {}
    for j, (_, r) in enumerate(items):
        by_side.setdefault(r.obstacles.shape[0], []).append(j)
    order: list[int] = []
    ordered, snapped, hidden = [0, 0], [0, 0], [0, 0, 0.0, 0]
    for side in sorted(by_side):
        idx = by_side[side]
        for s in range(0, len(idx), batch_size):
            sel = idx[s:s + batch_size]
            x, region, guide, dist_t = stack([items[j][1] for j in sel], encoding, distance=True)
            r, g, d = predict_all(model, x, bf16)
            if d is not None:  # the order of the distances themselves: manhattan + detour
                for j in range(len(sel)):
                    t, base = dist_t[j, 0].numpy(), dist_t[j, 1].numpy()
                    truth = np.where(t >= 0, t + base, -1.0)
                    got = order_accuracy(d[j] + base, truth)
                    ordered = [u + v for u, v in zip(ordered, got)]
                    got = order_accuracy(snap_detour(DISTANCE_UNIT * d[j]) / DISTANCE_UNIT + base, truth)
                    snapped = [u + v for u, v in zip(snapped, got)]
                    item = items[sel[j]][1]
                    if item.unknown is not None:
                        got = hidden_route_counts(d[j], t, base, item.unknown & item.region)
                        hidden = [u + v for u, v in zip(hidden, got)]
            rf.extend(f1_per_image(r >= 0.5, region[:, 0].numpy() > 0.5).tolist())
            gf.extend((f1_per_image(g >= 0.5, guide[:, 0].numpy() > 0.5) if g is not None else np.full(len(sel), np.nan)).tolist())
            order.extend(sel)
    groups = [items[j][0] for j in order]
    rf_a, gf_a = np.array(rf), np.array(gf)
    out = {"region_f1": float(100 * rf_a.mean()) if len(rf_a) else float("nan"),
           "guideline_f1": float(100 * np.nanmean(gf_a)) if np.isfinite(gf_a).any() else float("nan")}
    if ordered[1]:
        out["distance_order/all"] = 100.0 * ordered[0] / ordered[1]
        out["distance_order_snapped/all"] = 100.0 * snapped[0] / snapped[1]
    if hidden[1]:
        out["distance_order/hidden_route"] = 100.0 * hidden[0] / hidden[1]
    if hidden[3]:
        out["detour_error/hidden_route"] = hidden[2] / hidden[3]
    for name in sorted(set(groups)):
        sel = np.array([g == name for g in groups])
        out[f"region_f1/{name}"] = float(100 * rf_a[sel].mean())
        out[f"guideline_f1/{name}"] = float(100 * np.nanmean(gf_a[sel])) if np.isfinite(gf_a[sel]).any() else float("nan")
    return out
