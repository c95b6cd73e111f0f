"""Statistics of the experiment tables (docs/method.md: mean, median, 95% CI, non-converged runs).

The confidence interval is the Student-t interval of the mean, as in
:func:`ndrql.planning.results.summarize` (which this module reuses); a share of maps (e.g. "beats
IQL") takes the Wilson score interval (:func:`wilson_interval`).
"""

from __future__ import annotations

import math
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from ndrql.planning.results import summarize

__all__ = ["summarize", "describe", "relative_improvement", "per_map_improvement", "run_steps", "share_of_oracle", "fmt",
           "fmt_ci", "wilson_interval"]


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
