"""What a Q-learning run reports (docs/method.md): :class:`PlanResult` and its JSON form."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np


@dataclass(frozen=True)
class EpisodeRecords:
    """Per-episode records of one run (arrays of length ``episodes``)."""

    steps: np.ndarray
    """Moves made in each training episode (blocked moves count)."""
    returns: np.ndarray
    """Sum of rewards of each training episode."""
    success: np.ndarray
    """Whether the episode reached the goal."""
    greedy_length: np.ndarray
    """Length (moves) of the greedy rollout after the episode; -1 when it failed."""

    def to_dict(self) -> dict[str, list]:
        return {
            "steps": self.steps.tolist(),
            "returns": self.returns.tolist(),
            "success": self.success.astype(bool).tolist(),
            "greedy_length": self.greedy_length.tolist(),
        }


@dataclass(frozen=True)
class PlanResult:
    """Outcome of one Q-learning run on one planning grid with one method and one seed.

    Episode numbers are 1-based counts (``convergence_episode = 12`` means 12 training episodes).
    Lengths are in moves on the planning grid; points are planning-grid ``[row, col]``.
    """

    method: str
    """Method name from the registry (``QL``, ``IQL``, ``NDR-QL``, ...)."""
    seed: int
    """Seed of the kernel's generator; the same seed gives the same run."""
    converged: bool
    """Whether the greedy path was stable for W episodes within ``max_episodes``."""
    convergence_episode: int | None
    """Training episodes up to and including convergence (``None`` if not converged)."""
    convergence_steps: int | None
    """Environment steps summed over those episodes (rollouts not counted)."""
    episodes: int
    """Training episodes actually run."""
    total_steps: int
    """Environment steps over all episodes run."""
    path: list[list[int]] | None
    """Greedy path ``[[row, col], ...]`` at convergence (if not converged: the last greedy path that reached the goal, or ``None``)."""
    path_length: int | None
    """Moves of :attr:`path`."""
    astar_length: int
    """Optimal 4-connected path length (A* on the same planning grid)."""
    length_ratio: float | None
    """``path_length / astar_length`` (>= 1)."""
    shortest_success_length: int | None
    """Fewest moves among training episodes that reached the goal, up to convergence (paper style)."""
    longest_success_length: int | None
    """Most moves among training episodes that reached the goal, up to convergence (paper style)."""
    first_success_episode: int | None
    """1-based episode that first reached the goal (``None`` if none did)."""
    threshold: float | None
    """NDR-QI's adaptive threshold (Eq. 7); ``None`` without NDR-QI or when none connected."""
    wall_time: float
    """Seconds for priors plus training, in the process that ran it."""
    records: EpisodeRecords | None = field(default=None, compare=False, repr=False)
    """Per-episode records, kept only when asked for (``keep_records=True``)."""
    q_table: np.ndarray | None = field(default=None, compare=False, repr=False)
    """Final Q-table ``(cells, 4)``, kept only when asked for (``keep_q=True``); never in the JSON."""

    def to_dict(self, include_records: bool = False) -> dict[str, Any]:
        """Plain-JSON form; records only with ``include_records``."""
        out = {k: getattr(self, k) for k in self.__dataclass_fields__ if k not in ("records", "q_table")}
        if include_records and self.records is not None:
            out["records"] = self.records.to_dict()
        return out

    def to_json(self, include_records: bool = False, **kwargs: Any) -> str:
        return json.dumps(self.to_dict(include_records), **kwargs)

    def same_run(self, other: "PlanResult") -> bool:
        """Equal in everything but wall time (the determinism check)."""
        a = self.to_dict()
        b = other.to_dict()
        a.pop("wall_time")
        b.pop("wall_time")
        return a == b


def geometric_ci(values: list[float | int | None]) -> tuple[float, float] | None:
    """A 95% interval of the geometric mean of positive counts (steps): :func:`summarize`'s interval of the
    mean of their logs, turned back. Never below zero, as steps are not, and fit to their skew; ``None``
    for fewer than two positive values."""
    logs = [math.log(v) for v in values if v is not None and v > 0]
    st = summarize(logs)
    if st["ci95_low"] is None or not math.isfinite(st["ci95_low"]):
        return None
    return math.exp(st["ci95_low"]), math.exp(st["ci95_high"])


def summarize(values: list[float | int | None]) -> dict[str, float | int | None]:
    """Mean, median and a 95% confidence interval of the mean (Student t) over non-``None`` values."""
    vals = np.asarray([v for v in values if v is not None], dtype=np.float64)
    n = int(vals.size)
    if n == 0:
        return {"n": 0, "mean": None, "median": None, "ci95_low": None, "ci95_high": None}
    mean = float(vals.mean())
    if n > 1:
        from scipy import stats

        half = float(stats.t.ppf(0.975, n - 1) * vals.std(ddof=1) / math.sqrt(n))
    else:
        half = float("nan")
    return {
        "n": n,
        "mean": mean,
        "median": float(np.median(vals)),
        "ci95_low": mean - half if n > 1 else None,
        "ci95_high": mean + half if n > 1 else None,
    }
