"""The one judge: whether a prior source's prediction can guide NDR-QL on this planning grid.

:func:`judge` runs **one** Eq. 7 search per prediction (:func:`~ndrql.planning.priors.adaptive_threshold` on the
region widened as Eq. 6 widens it, with the NDR method's own constants), and the priors then take that threshold
as it is (:func:`ndrql.planning.methods.build_priors`'s ``threshold``): the threshold the judge saw is the one the
Q-table is built with. A prediction is rejected when

- no threshold of at least :func:`~ndrql.pipeline.fallback.min_threshold` joins start and goal (0 up to 128 cells,
  0.1 above);
- above 128 cells, the region covers more than half of the free cells at its threshold (it does not say where the
  path runs);
- more than half of the guideline's mass lies on obstacles (the model draws its path through walls);
- the region is the same on every free cell (a constant output says nothing of where the path runs);
- the route the region allows (the fewest 4-connected moves from start to goal through the free cells above the
  threshold) is longer than :data:`MAX_ROUTE_RATIO` times the shortest route of the planner's grid: Eq. 6's mask
  then steers the agent along a detour, which the exact distance never does.

Where every source of the policy is rejected, the plan falls back to the exact-distance prior (IQL-BFS,
:data:`~ndrql.pipeline.request.DEFAULT_FALLBACK`); :mod:`ndrql.pipeline.sources` keeps the typed trace.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ndrql.errors import NdrqlError
from ndrql.maps.grid import bfs_distances
from ndrql.pipeline.fallback import MAX_GUIDE_ON_OBSTACLES, region_reason
from ndrql.planning.config import PriorConfig
from ndrql.planning.priors import adaptive_threshold, widen_region

Point = tuple[int, int]

#: Longest route through the region, as a multiple of the grid's shortest route, that still guides planning: the
#: region must hold a shortest route. Chosen by rule 2 of studies/judge/README.md from none, 1.25, 1.10, 1.05 and 1.00
#: on the development runs (grids 50, 100, 128, 256): the strict cut gave the lowest worst family of NDR-QL with the
#: network's priors against IQL-BFS (1.017 at 128 cells; 1.022 at 1.05, 1.045 without a cut). It matters where the
#: network is asked (``--prior-from model``, belief maps); the exact source's route is the shortest by construction.
MAX_ROUTE_RATIO = 1.0


@dataclass(frozen=True)
class Verdict:
    """What the judge found of one prediction (JSON: an entry of ``sources``)."""

    accepted: bool
    """Whether the prediction guides planning."""
    threshold: float | None
    """Eq. 7's threshold (the highest of the method's schedule that joins start and goal), ``None``: none does."""
    cover: float | None
    """Share of the free cells inside the region at :attr:`threshold`."""
    guideline_on_obstacles: float | None
    """Share of the guideline's mass on obstacle cells of the grid (``None`` without a guideline)."""
    route_ratio: float | None
    """Moves from start to goal through the region at :attr:`threshold` over the grid's shortest route."""
    reason: str | None
    """Why it was rejected (``None`` when accepted)."""

    def to_dict(self) -> dict[str, Any]:
        """Plain types, rounded for the JSON."""
        def r(v: float | None, k: int = 4) -> float | None:
            return None if v is None else round(float(v), k)
        return {"accepted": self.accepted, "threshold": r(self.threshold), "region_cover": r(self.cover),
                "guideline_on_obstacles": r(self.guideline_on_obstacles), "route_ratio": r(self.route_ratio),
                "reason": self.reason}


def route_ratio(region: np.ndarray, blocked: np.ndarray, start: Point, goal: Point, thd: float,
                shortest: int | None = None) -> float | None:
    """Fewest 4-connected moves from ``start`` to ``goal`` through the free cells with ``region > thd``, over the
    fewest through all free cells (``shortest``, computed when not given); ``None`` where either does not join them."""
    blocked = np.asarray(blocked, dtype=bool)
    if shortest is None:
        shortest = int(bfs_distances(blocked, goal)[tuple(start)])
    if shortest <= 0:
        return None if shortest < 0 else 1.0
    inside = int(bfs_distances(blocked | ~(np.asarray(region) > thd), goal)[tuple(start)])
    return None if inside < 0 else inside / shortest


def guideline_on_obstacles(guideline: np.ndarray | None, blocked: np.ndarray) -> float | None:
    """Share of the guideline's mass on blocked cells (``None`` without a guideline or with an empty one)."""
    if guideline is None:
        return None
    g = np.asarray(guideline, dtype=np.float64)
    mass = float(g.sum())
    return None if mass <= 0 else float(g[np.asarray(blocked, dtype=bool)].sum()) / mass


def judge(region: np.ndarray, guideline: np.ndarray | None, blocked: np.ndarray, start: Point, goal: Point,
          cfg: PriorConfig, shortest: int | None = None, max_route_ratio: float = MAX_ROUTE_RATIO) -> Verdict:
    """The verdict on one prediction on a planning grid (module docstring): one Eq. 7 search with ``cfg`` (the NDR
    method's constants on this grid) on the region widened by ``cfg.region_dilation``; ``shortest``: the grid's
    shortest route in 4-connected moves when the caller has it."""
    blocked = np.asarray(blocked, dtype=bool)
    widened = widen_region(np.asarray(region, dtype=np.float64), cfg.region_dilation)
    thd = adaptive_threshold(widened, blocked, start, goal, cfg)
    free = ~blocked
    cover = None if thd is None or not free.any() else float(np.count_nonzero((widened > thd) & free) / free.sum())
    on_obstacles = guideline_on_obstacles(guideline, blocked)
    reasons = []
    why = region_reason(thd, cover, max(blocked.shape))
    if why:
        reasons.append(why)
    elif free.any() and np.ptp(widened[free]) == 0:  # a constant graph, an empty head: it joins at any threshold
        reasons.append("the region is the same on every free cell (it says nothing of where the path runs)")
    if guideline is not None and on_obstacles is None:
        reasons.append("the guideline is empty")
    elif on_obstacles is not None and on_obstacles > MAX_GUIDE_ON_OBSTACLES:
        reasons.append(f"{on_obstacles:.0%} of the guideline lies on obstacles")
    ratio = None
    if thd is not None:
        ratio = route_ratio(widened, blocked, start, goal, thd, shortest)
        if ratio is not None and ratio > max_route_ratio:
            reasons.append(f"the region's route is {ratio:.2f}x the shortest (at most {max_route_ratio:.2f}x)")
    return Verdict(not reasons, thd, cover, on_obstacles, ratio, "; ".join(reasons) or None)


@dataclass(frozen=True)
class Trial:
    """One source asked by :func:`consult` (JSON: an entry of ``sources``)."""

    source: str
    """The source's name."""
    seconds: float
    """Wall seconds it took (0 when it was not asked)."""
    verdict: Verdict | None
    """The judge's verdict (``None`` when it gave nothing: over the budget or failed)."""
    reason: str | None = None
    """Why it gave nothing, or why the judge rejected it."""

    @property
    def accepted(self) -> bool:
        return self.verdict is not None and self.verdict.accepted

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"source": self.source, "seconds": round(self.seconds, 4), "accepted": self.accepted,
                               "reason": self.reason}
        if self.verdict is not None:
            out.update({k: v for k, v in self.verdict.to_dict().items() if k not in ("accepted", "reason")})
        return out


def _timed_call(fn: Any, seconds: float | None) -> tuple[Any, BaseException | None, bool]:
    """``fn()`` with at most ``seconds`` of wall time (``None``: no limit): ``(value, error, finished)``. An
    unfinished call is left to end on its own daemon thread; its result is dropped."""
    if seconds is None:
        try:
            return fn(), None, True
        except Exception as exc:  # noqa: BLE001 (handed back to the caller, who re-raises NdrqlError)
            return None, exc, True
    box: dict[str, Any] = {}

    def target() -> None:
        try:
            box["value"] = fn()
        except BaseException as exc:  # noqa: BLE001
            box["error"] = exc

    t = threading.Thread(target=target, name="ndrql-source", daemon=True)
    t.start()
    t.join(max(0.0, seconds))
    if t.is_alive():
        return None, None, False
    return box.get("value"), box.get("error"), True


def consult(sources: Any, problem: Any, cfg: PriorConfig, deadline: float | None = None,
            clock: Any = time.perf_counter, max_route_ratio: float | None = None) -> tuple[Any, tuple[Trial, ...], Any]:
    """Ask ``sources`` (each a :class:`~ndrql.pipeline.sources.PriorSource`) in order on ``problem`` (a
    :class:`~ndrql.pipeline.sources.SourceInput`) and judge each (:func:`judge` with ``cfg``) until one is accepted.

    ``deadline``: a ``clock()`` time after which no bounded source (``src.bounded``: the networks) is asked and a
    running one is abandoned (said in its trial: "over the time budget"); the others run inline. Returns ``(accepted priors or None, the trials, the first priors given)``; the
    last lets a plan without fallback still use a rejected prediction. ``max_route_ratio``: the route test's cut
    (default :data:`MAX_ROUTE_RATIO`; on a belief map none, ``inf``: the belief's shortest route is an optimist's,
    and a prediction that knows a hidden wall's detour must not be rejected for it). An :class:`~ndrql.errors.NdrqlError` raised
    by a source propagates; any other failure is a rejected trial with its message.
    """
    trials: list[Trial] = []
    first = None
    g = problem.grid
    shortest: int | None = None
    for src in sources:
        bounded = getattr(src, "bounded", True)
        left = None if deadline is None or not bounded else deadline - clock()
        if left is not None and left <= 0:
            trials.append(Trial(src.name, 0.0, None, "not asked: the time budget was spent"))
            continue
        t0 = clock()
        value, error, finished = _timed_call(lambda: src.give(problem), left)
        took = clock() - t0
        if not finished:
            trials.append(Trial(src.name, took, None, f"over the time budget ({took:.2f} s; --predict-budget)"))
            continue
        if error is not None:
            if isinstance(error, NdrqlError):
                raise error
            if type(error).__name__ == "SourceDeclined":  # the source said why it cannot serve this problem
                trials.append(Trial(src.name, took, None, str(error)))
                continue
            trials.append(Trial(src.name, took, None, f"failed: {type(error).__name__}: {error}"))
            continue
        if shortest is None:
            shortest = int(bfs_distances(g.blocked, g.goal)[tuple(g.start)])
        verdict = judge(value.region, value.guideline, g.blocked, g.start, g.goal, cfg, shortest,
                        MAX_ROUTE_RATIO if max_route_ratio is None else max_route_ratio)
        first = first if first is not None else (value, verdict)
        trials.append(Trial(src.name, clock() - t0, verdict, verdict.reason))
        if verdict.accepted:
            return (value, verdict), tuple(trials), first
    return None, tuple(trials), first
