"""Whether the model's prediction can guide planning, and the method that runs instead when it cannot.

:func:`prediction_quality` judges a prediction on the planning grid; :func:`fall_back` swaps each NDR
method for the request's fallback when the prediction is uninformative, records the swap as a
:class:`Fallback` (each run then carries ``requested_method`` and ``fallback_reason``) and warns with a
:class:`~ndrql.errors.FallbackWarning`: the method that runs is never silently another.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ndrql.errors import FallbackWarning
from ndrql.maps.grid import PlanningGrid
from ndrql.planning.methods import Method, get_method
from ndrql.planning.priors import adaptive_threshold

#: The region threshold (Eq. 7) below which the prediction is called uninformative. 0: only a region
#: that joins start and goal at no threshold at all is; measured as ``plan`` runs on generated
#: development maps (``studies/plan_defaults``), NDR-QL beat IQL on every map a cut of 0.3-0.6 sent to
#: IQL (Eq. 7 thresholds down to 0.00), so any cut only lost maps (0.5 lost 8 of 36).
MIN_THRESHOLD = 0.0
#: Grids of more cells per side than this judge the prediction by :data:`LARGE_MIN_THRESHOLD` instead.
LARGE_GRID = 128
#: The cut above :data:`LARGE_GRID` cells (grids the view merges, where the large-grid companion predicts).
#: There a region that joins start and goal only below this threshold costs steps instead of saving them:
#: on the development sets ``large-dev-256`` and ``large-tune-256`` (108 maps) NDR-QL took 2.1x IQL's steps
#: in geometric mean on such maps, and of the cuts 0.02, 0.05 and 0.1 this one gave plan the fewest steps
#: (studies/large_view/history.md#low-thresholds-on-large-grids); at 50-100 cells such maps still win (above).
LARGE_MIN_THRESHOLD = 0.1


def min_threshold(cells: int) -> float:
    """The Eq. 7 threshold below which a prediction on a planning grid of ``cells`` cells on its longer
    side is uninformative: :data:`MIN_THRESHOLD`, or :data:`LARGE_MIN_THRESHOLD` above :data:`LARGE_GRID`."""
    return LARGE_MIN_THRESHOLD if cells > LARGE_GRID else MIN_THRESHOLD


#: Largest share of the guideline's probability mass that may lie on obstacle pixels.
MAX_GUIDE_ON_OBSTACLES = 0.5
#: Above :data:`LARGE_GRID` cells, the largest share of the free cells the region may cover at its Eq. 7
#: threshold: a region over most of the map does not say where the path runs, and Eq. 8 then rewards almost
#: every cell. Seen where the companion sees a grid at 1 px per cell (a 1,024 px maze planned at 512 cells:
#: the region covered 93% of the free cells at threshold 0.81 and NDR-QL took 5.7x IQL's steps;
#: studies/large_view/history.md#a-region-over-the-whole-map). On 50-128 cells a 7.5-cell band may fairly cover most
#: of a small open map, so the test is not applied there.
MAX_REGION_COVER = 0.5


def region_cover(region: np.ndarray, blocked: np.ndarray, thd: float | None) -> float | None:
    """Share of the free cells inside the region at threshold ``thd`` (Eq. 7's ``N_r > thd``); ``None``
    when there is no threshold or no free cell."""
    free = ~np.asarray(blocked, dtype=bool)
    if thd is None or not free.any():
        return None
    return float(np.count_nonzero((np.asarray(region) > thd) & free) / np.count_nonzero(free))


def max_region_cover(cells: int) -> float | None:
    """The largest region cover (:func:`region_cover`) an informative prediction may have on a planning grid of
    ``cells`` cells on its longer side: :data:`MAX_REGION_COVER` above :data:`LARGE_GRID`, else no limit."""
    return MAX_REGION_COVER if cells > LARGE_GRID else None


def region_reason(thd: float | None, cover: float | None, cells: int, cut: float | None = None) -> str | None:
    """Why the region cannot guide planning on a grid of ``cells`` cells, or ``None`` when it can: no Eq. 7
    threshold of at least ``cut`` (default :func:`min_threshold`) joins start and goal (``thd`` the highest that
    does), or it covers more of the free cells at ``thd`` than :func:`max_region_cover` allows (``cover`` from
    :func:`region_cover`; ``None``: not tested). One rule for ``plan`` and the reports that replay it."""
    cut = min_threshold(cells) if cut is None else cut
    if thd is None or thd < cut:
        shown = "none" if thd is None else f"{thd:.2f}"
        floor = f" >= {cut}" if cut > 0 else ""
        return f"no region threshold{floor} connects start and goal (Eq. 7 threshold {shown})"
    limit = max_region_cover(cells)
    if limit is not None and cover is not None and cover > limit:
        return (f"the region covers {cover:.0%} of the free cells at its Eq. 7 threshold {thd:.2f} "
                f"(at most {limit:.0%} above {LARGE_GRID} cells)")
    return None


def region_verdict(region: np.ndarray, blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int],
                   cfg: Any) -> tuple[float | None, float | None, str | None]:
    """``(thd, cover, reason)`` of a region on a planning grid: its Eq. 7 threshold (``cfg`` a
    :class:`~ndrql.planning.config.PriorConfig`), its cover there (:func:`region_cover`) and why it cannot
    guide planning (:func:`region_reason`; ``None``: it can)."""
    thd = adaptive_threshold(region, blocked, start, goal, cfg)
    cover = region_cover(region, blocked, thd)
    return thd, cover, region_reason(thd, cover, max(np.shape(blocked)))


def prediction_quality(region_grid: np.ndarray, guideline: np.ndarray | None, obstacles: np.ndarray,
                       grid: PlanningGrid, cfg: Any) -> dict[str, Any]:
    """Whether the model's prediction can guide planning on this problem (JSON ``prediction_quality``).

    Uninformative when no region threshold of at least :func:`min_threshold` (0 up to 128 cells) makes the
    region connect start and goal on the planning grid (Eq. 7's search, ``cfg`` a
    :class:`~ndrql.planning.config.PriorConfig`),
    or when more than :data:`MAX_GUIDE_ON_OBSTACLES` of the guideline's mass lies on obstacles of
    the map (the model draws its path through walls), or, above 128 cells, when the region covers more than
    :data:`MAX_REGION_COVER` of the free cells at that threshold (it does not say where the path runs).
    """
    thd, cover, why = region_verdict(region_grid, grid.blocked, grid.start, grid.goal, cfg)
    cells = max(grid.blocked.shape)
    reasons = [why] if why else []
    on_obstacles = None
    if guideline is not None:
        mass = float(np.sum(guideline))
        if mass > 0:
            on_obstacles = float(np.sum(guideline, where=np.asarray(obstacles, dtype=bool))) / mass
            if on_obstacles > MAX_GUIDE_ON_OBSTACLES:
                reasons.append(f"{on_obstacles:.0%} of the guideline lies on obstacles")
        else:
            reasons.append("the guideline is empty")
    return {"informative": not reasons, "threshold": thd, "min_threshold": min_threshold(cells), "region_cover": cover,
            "guideline_on_obstacles": on_obstacles, "reasons": reasons}


@dataclass(frozen=True)
class Fallback:
    """An NDR method that did not run because the prediction was uninformative, and what ran instead."""

    requested: str
    """The method asked for."""
    ran: str
    """The method that ran instead."""
    reason: str
    """Why (the prediction's quality, :func:`prediction_quality`)."""


def fall_back(ms: Sequence[Method], quality: dict[str, Any], fallback: str | None) -> tuple[list[Method], list[Fallback]]:
    """The methods to run after judging the prediction (``quality``): when it is uninformative and
    ``fallback`` is set, each NDR method is replaced by the fallback, unless that one runs anyway; and
    the replacements made (:func:`warn_fallbacks` tells the caller)."""
    if quality["informative"] or fallback is None:
        return list(ms), []
    fb = get_method(fallback)
    if any(m.name == fb.name for m in ms):
        return list(ms), []
    reason = "the prediction is uninformative: " + "; ".join(quality["reasons"])
    out: list[Method] = []
    swaps: list[Fallback] = []
    for m in ms:
        m2 = fb if m.needs_ndr else m
        if m2 is not m:
            swaps.append(Fallback(m.name, fb.name, reason))
        if all(x.name != m2.name for x in out):
            out.append(m2)
    return out, swaps


def warn_fallbacks(swaps: Sequence[Fallback], stacklevel: int = 2) -> None:
    """One :class:`~ndrql.errors.FallbackWarning` per replaced method, pointing at the caller's line."""
    for f in swaps:
        warnings.warn(f"{f.requested} did not run, {f.ran} ran instead ({f.reason}; fallback none keeps the "
                      f"model's priors)", FallbackWarning, stacklevel=stacklevel + 1)
