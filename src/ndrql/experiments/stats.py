"""Statistics of the experiment tables (docs/method.md: mean, median, 95% CI, non-converged runs).

The confidence interval is the Student-t interval of the mean, as in
:func:`ndrql.planning.results.summarize` (which this module reuses); a share of maps (e.g. "beats
IQL") takes the Wilson score interval (:func:`wilson_interval`). Comparisons of two methods over maps
lead with the geometric mean of the per-map step ratios and a seeded bootstrap interval over the maps
(:func:`geomean_ratio`); a single map is a clear win, a tie or a clear loss by a test over its seeds
(:func:`compare_seeds`); pooled sums come with the same figure without the largest map (:func:`pooled_ratio`).
"""

from __future__ import annotations

import math
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from ndrql.planning.results import summarize

__all__ = ["summarize", "describe", "relative_improvement", "per_map_improvement", "run_steps", "share_of_oracle", "share_of_oracle_geomean", "fmt",
           "fmt_ci", "wilson_interval", "geomean_ratio", "pooled_ratio", "compare_seeds", "outcomes", "tally", "BOOTSTRAP",
           "TIE", "ALPHA"]

#: Bootstrap resamples of the maps for an interval (seeded: the same records give the same interval).
BOOTSTRAP = 4000
#: Relative gap in mean steps within which a map is a tie whatever its seeds say (:func:`compare_seeds`).
TIE = 0.005
#: Two-sided level of the test over seeds (:func:`compare_seeds`).
ALPHA = 0.05


def describe(values: Iterable[float | int | None]) -> dict[str, float | int | None]:
    """:func:`summarize` plus ``missing`` (the ``None`` values, e.g. runs that did not converge), min and max."""
    vals = list(values)
    out = dict(summarize(vals))
    present = [float(v) for v in vals if v is not None]
    out["missing"] = len(vals) - len(present)
    out["min"] = min(present) if present else None
    out["max"] = max(present) if present else None
    return out


def relative_improvement(method_steps: Sequence[float], baseline_steps: Sequence[float]) -> float:
    """``1 - sum(method) / sum(baseline)`` over maps: the paper's "improves convergence by X%".

    This is the definition that reproduces the paper's own figures from its Table 3 (NDR-QL 90%,
    O-QL 80%, IQL 58%); the mean of per-map improvements gives 89%, 80%, 50% there
    (:func:`per_map_improvement`).
    """
    m = np.asarray(method_steps, dtype=np.float64)
    b = np.asarray(baseline_steps, dtype=np.float64)
    if m.shape != b.shape or m.size == 0:
        raise ValueError(f"need the same non-empty set of maps, got {m.shape} and {b.shape}")
    return float(1.0 - m.sum() / b.sum())


def per_map_improvement(method_steps: Sequence[float], baseline_steps: Sequence[float]) -> float:
    """Mean over maps of ``1 - method / baseline``."""
    m = np.asarray(method_steps, dtype=np.float64)
    b = np.asarray(baseline_steps, dtype=np.float64)
    if m.shape != b.shape or m.size == 0:
        raise ValueError(f"need the same non-empty set of maps, got {m.shape} and {b.shape}")
    return float(np.mean(1.0 - m / b))


def run_steps(run: Mapping[str, Any]) -> int:
    """Steps a stored run cost: its convergence steps, or every step it ran when it did not converge."""
    return int(run["convergence_steps"] if run["converged"] else run["total_steps"])


def share_of_oracle(model_steps: Sequence[float], oracle_steps: Sequence[float], baseline_steps: Sequence[float]) -> float:
    """The model's share of the oracle's reduction: ``(1 - model/QL) / (1 - oracle/QL)`` on pooled steps.

    The three sequences hold steps of the same maps and seeds in the same order (per map, or per run);
    each ratio is :func:`relative_improvement`. NaN when the oracle needs no fewer steps than the baseline.
    """
    oracle = relative_improvement(oracle_steps, baseline_steps)
    return relative_improvement(model_steps, baseline_steps) / oracle if oracle > 0 else float("nan")


def share_of_oracle_geomean(model_ratio: float, oracle_ratio: float) -> float:
    """The model's share of the oracle's gain over a baseline from geometric means of per-map step ratios
    (model / baseline and oracle / baseline, :func:`geomean_ratio`): ``(1 - model) / (1 - oracle)``. NaN when
    the oracle is not faster than the baseline (every map weighs alike, unlike :func:`share_of_oracle`)."""
    return (1 - model_ratio) / (1 - oracle_ratio) if oracle_ratio < 1 else float("nan")


def fmt(v: float | int | None, nd: int = 0) -> str:
    """Number with thousands separators, ``-`` for missing/NaN."""
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-"
    return f"{v:,.{nd}f}"


def fmt_ci(s: Mapping[str, float | int | None], nd: int = 0) -> str:
    """``[low, high]`` of a :func:`summarize` dict, ``-`` when undefined (fewer than 2 values)."""
    if s.get("ci95_low") is None:
        return "-"
    return f"[{fmt(s['ci95_low'], nd)}, {fmt(s['ci95_high'], nd)}]"


def wilson_interval(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """The Wilson score interval of a share ``successes / n`` (95% for the default ``z``).

    Unlike the normal approximation it stays inside [0, 1] and is sensible at 0 and ``n`` successes
    and for the few maps of one family; ``(nan, nan)`` for ``n = 0``.
    """
    if n <= 0:
        return math.nan, math.nan
    if not 0 <= successes <= n:
        raise ValueError(f"successes must lie in 0..{n}, got {successes}")
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


def _bootstrap_ids(n: int, seed: int, reps: int = BOOTSTRAP) -> np.ndarray:
    """``reps`` resamples (with replacement) of ``n`` map indices, from a seeded generator."""
    return np.random.default_rng(seed).integers(0, n, size=(reps, n))


def geomean_ratio(a: Sequence[float], b: Sequence[float], seed: int = 0, reps: int = BOOTSTRAP) -> dict[str, float]:
    """Geometric mean over maps of ``a_i / b_i`` (per-map mean steps of two methods) and its 95% percentile
    bootstrap interval over the maps (seeded). Every map weighs alike, whatever its size; ``ratio`` 0.5 means
    half the steps on a typical map. Keys ``ratio``, ``low``, ``high``, ``maps``."""
    x = np.log(np.asarray(a, np.float64)) - np.log(np.asarray(b, np.float64))
    if x.size == 0:
        return {"ratio": math.nan, "low": math.nan, "high": math.nan, "maps": 0}
    boot = x[_bootstrap_ids(x.size, seed, reps)].mean(axis=1)
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return {"ratio": float(np.exp(x.mean())), "low": float(np.exp(lo)), "high": float(np.exp(hi)), "maps": int(x.size)}


def pooled_ratio(a: Sequence[float], b: Sequence[float], seed: int = 0, reps: int = BOOTSTRAP) -> dict[str, float]:
    """``sum(a) / sum(b)`` over maps with its 95% bootstrap interval over the maps (seeded), and the same ratio
    without the largest map (the one with the most steps of the two together), which a pooled sum can hinge
    on. Keys ``ratio``, ``low``, ``high``, ``without_largest``, ``largest`` (its index)."""
    a_, b_ = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if a_.size == 0:
        return {"ratio": math.nan, "low": math.nan, "high": math.nan, "without_largest": math.nan, "largest": -1}
    ids = _bootstrap_ids(a_.size, seed, reps)
    lo, hi = np.percentile(a_[ids].sum(axis=1) / b_[ids].sum(axis=1), [2.5, 97.5])
    big = int(np.argmax(a_ + b_))
    rest = np.arange(a_.size) != big
    without = float(a_[rest].sum() / b_[rest].sum()) if rest.any() else math.nan
    return {"ratio": float(a_.sum() / b_.sum()), "low": float(lo), "high": float(hi), "without_largest": without,
            "largest": big}


def compare_seeds(a: Sequence[float], b: Sequence[float], tie: float = TIE, alpha: float = ALPHA) -> int:
    """One map: ``-1`` a clear win of ``a`` (fewer steps), ``1`` a clear loss, ``0`` a tie.

    Clear means both: the mean steps differ by more than ``tie`` (relative to ``b``'s), and Welch's t-test
    on the log steps of the seeds rejects equal means at level ``alpha`` (two-sided). Runs of one seed
    are not paired across methods (each method draws its own exploration), hence the unpaired test. With
    no spread in either (every seed the same steps) any difference counts; a single seed per method
    cannot be tested and is a tie unless the gap exceeds ``tie``."""
    from scipy import stats as sps  # lazy: loads scipy

    x, y = np.log(np.asarray(a, np.float64)), np.log(np.asarray(b, np.float64))
    gap = float(np.mean(np.exp(x)) / np.mean(np.exp(y)) - 1)
    if abs(gap) <= tie:
        return 0
    sign = -1 if gap < 0 else 1
    if x.size < 2 or y.size < 2:
        return sign
    vx, vy = x.var(ddof=1) / x.size, y.var(ddof=1) / y.size
    se = math.sqrt(vx + vy)
    if se == 0:
        return sign if x.mean() != y.mean() else 0
    t = (x.mean() - y.mean()) / se
    df = (vx + vy) ** 2 / ((vx * vx / (x.size - 1) if vx else 0.0) + (vy * vy / (y.size - 1) if vy else 0.0))
    p = 2 * float(sps.t.sf(abs(t), df))
    return sign if p < alpha else 0


def outcomes(a: Sequence[Sequence[float]], b: Sequence[Sequence[float]], tie: float = TIE,
             alpha: float = ALPHA) -> dict[str, Any]:
    """Clear wins, ties and clear losses of ``a`` against ``b`` over maps (:func:`compare_seeds` on each map's
    seeds), with the share of clear wins and its Wilson interval. Keys ``wins``, ``ties``, ``losses``,
    ``maps``, ``win_share``, ``win_ci``."""
    return tally([compare_seeds(x, y, tie, alpha) for x, y in zip(a, b)])


def tally(res: Sequence[int]) -> dict[str, Any]:
    """:func:`outcomes`' figures from one result per map (``-1`` clear win, ``0`` tie, ``1`` clear loss)."""
    res = list(res)
    wins, ties, losses = res.count(-1), res.count(0), res.count(1)
    n = len(res)
    return {"wins": wins, "ties": ties, "losses": losses, "maps": n, "win_share": wins / n if n else math.nan,
            "win_ci": list(wilson_interval(wins, n))}
