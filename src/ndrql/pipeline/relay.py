"""A relay: the model asked again from where its own region ends (docs/large-maps.md#a-relay).

On a large grid the companion's region can break between start and goal: the part joined to the start
ends somewhere short of the goal (mazes, floors of many rooms, whose route depends on the whole map). A
relay asks the same model again, for the same goal, from the cell of that part which the model's own
distance head puts nearest the goal, and takes the union of the regions (and of the guidelines); it hops
again while the union still breaks, up to :data:`MAX_HOPS` times. Where that does not join them, the way
back: the model is asked for the reversed problem (from the goal to the start) and relayed from the goal's
part of the union the same way, towards the start (docs/large-maps.md#what-the-uninformative-maps-have-in-common).
Every region, guideline and distance is the model's own and every hop starts where its own outputs point;
nothing searches the grid for a route (joining the region's pieces by a shortest path was tried and rejected
for that reason, docs/large-maps.md#a-second-opinion).

:func:`relay` is called by :func:`ndrql.pipeline.predictions.predict_on_grid` only above 128 cells and
only where the companion and the base model were both uninformative; its verdict uses the same test
(:func:`~ndrql.pipeline.fallback.region_verdict`). Where it fails, :func:`turned_relay` asks the companion again
averaged over :data:`TURNS` orientations of the grid, and relays that
(docs/large-maps.md#four-orientations-where-the-relay-fails-rule-written-2026-11-27-before-its-runs).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ndrql.pipeline.fallback import min_threshold, region_verdict

Point = tuple[int, int]

#: Most hops of a relay. On the development maps where both models were uninformative the relays that
#: joined start and goal took 1-3 hops (docs/large-maps.md#a-relay); each hop is one more forward pass.
MAX_HOPS = 4
#: Orientations of the grid averaged when the relay of one orientation fails (:func:`turned_relay`).
TURNS = 4


def start_part(region: np.ndarray, blocked: np.ndarray, start: Point, cut: float) -> np.ndarray:
    """The free cells 4-connected to ``start`` through region cells above ``cut`` (Eq. 7's ``N_r > cut``),
    ``start`` included; empty when ``start`` itself is not above ``cut``."""
    from scipy import ndimage  # lazy: only a relay needs it

    inside = (np.asarray(region) > cut) & ~np.asarray(blocked, bool)
    if not inside[start]:
        return np.zeros_like(inside)
    labels, _ = ndimage.label(inside)
    return labels == labels[start]


def next_hop(part: np.ndarray, distance: np.ndarray) -> Point | None:
    """The cell of ``part`` the model's goal distance puts nearest the goal (the first in row-major order on a
    tie); ``None`` for an empty part."""
    if not part.any():
        return None
    d = np.where(part, np.asarray(distance, np.float64), np.inf)
    return tuple(int(v) for v in np.unravel_index(int(np.argmin(d)), d.shape))  # type: ignore[return-value]


def _hops(predictor: Any, blocked: np.ndarray, start: Point, goal: Point, region: np.ndarray,
          guide: np.ndarray | None, distance: np.ndarray | None, cfg: Any, max_hops: int
          ) -> tuple[np.ndarray, np.ndarray | None, list[list[int]], str | None]:
    """One direction of a relay: from the part of ``region`` joined to ``start``, at most ``max_hops`` predictions
    for ``goal``, each from the cell of that part ``distance`` (the goal distance of the direction's first
    prediction) puts nearest ``goal``, joined into ``region`` and ``guide``; ``(region, guide, hops, why)``, ``why``
    the verdict of :func:`~ndrql.pipeline.fallback.region_verdict` on the union (``None``: it can guide planning)."""
    cut = min_threshold(max(np.shape(blocked)))
    hops: list[list[int]] = []
    why = region_verdict(region, blocked, start, goal, cfg)[2]
    visited = {tuple(start)}
    while why is not None and distance is not None and len(hops) < max_hops:
        part = start_part(region, blocked, start, cut)
        if part[goal]:  # joined, but the region fails otherwise (it covers too much): another hop cannot help
            break
        cell = next_hop(part, distance)
        if cell is None or cell in visited:
            break
        visited.add(cell)
        hops.append([int(cell[0]), int(cell[1])])
        out = predictor.predict_view(blocked, cell, goal)
        region = np.maximum(region, out.region)
        guide = guide if guide is None or out.guideline is None else np.maximum(guide, out.guideline)
        why = region_verdict(region, blocked, start, goal, cfg)[2]
    return region, guide, hops, why


def relay(predictor: Any, blocked: np.ndarray, start: Point, goal: Point, first: Any, cfg: Any,
          max_hops: int = MAX_HOPS, back: bool = True) -> tuple[Any, dict[str, Any]]:
    """``first`` (a :class:`~ndrql.model.predict.CellPrediction` of the model that serves the grid, with a goal
    distance) relayed: at most ``max_hops`` more predictions of ``predictor`` for ``goal``, each from
    :func:`next_hop` of the start's part of the union so far (:func:`start_part` above the grid's
    :func:`~ndrql.pipeline.fallback.min_threshold`), until the union passes
    :func:`~ndrql.pipeline.fallback.region_verdict` (``cfg`` a :class:`~ndrql.planning.config.PriorConfig`).

    With ``back`` (the default), where those hops leave start and goal apart and the model has a distance, the
    way back: one prediction of the reversed problem (from ``goal`` to ``start``), joined, and at most ``max_hops``
    more from the goal's part of the union towards the start (its distance now the reversed prediction's).

    Returns the union (region and guideline the cellwise maxima, the first prediction's distance and
    view) and ``{"hops": [[row, col], ...], "served": bool, "reason": why it still cannot guide planning or
    None}``, with ``"back": [[row, col], ...]`` (the way back's hops) when the way back was asked. A prediction
    without a distance, or a part that cannot move on, ends a direction."""
    region = np.asarray(first.region, np.float64)
    guide = None if first.guideline is None else np.asarray(first.guideline, np.float64)
    region, guide, hops, why = _hops(predictor, blocked, start, goal, region, guide, first.distance, cfg, max_hops)
    info: dict[str, Any] = {"hops": hops}
    joined = start_part(region, blocked, start, min_threshold(max(np.shape(blocked))))[goal]
    if back and why is not None and first.distance is not None and not joined:
        rev = predictor.predict_view(blocked, goal, start)
        region = np.maximum(region, rev.region)
        guide = guide if guide is None or rev.guideline is None else np.maximum(guide, rev.guideline)
        region, guide, info["back"], why = _hops(predictor, blocked, goal, start, region, guide, rev.distance, cfg,
                                                  max_hops)
    info.update(served=why is None, reason=why)
    return replace(first, region=region, guideline=guide), info


def turned_relay(predictor: Any, blocked: np.ndarray, start: Point, goal: Point, first: Any, cfg: Any
                 ) -> tuple[Any, dict[str, Any]]:
    """:func:`relay` of ``first``; where its union still cannot guide planning and ``predictor`` averages fewer than
    :data:`TURNS` orientations (:meth:`~ndrql.model.predict.Predictor.with_symmetries`), the model asked again
    averaged over :data:`TURNS` orientations and, unless that already serves, relayed so. The turned prediction (or
    its union) is returned where it passes the test; otherwise the first relay's union, as without this step.
    ``info`` is :func:`relay`'s, with ``"turned"``: ``{"orientations", "hops", "back" (when asked), "served",
    "reason", "first_reason"}`` (the last the one-orientation relay's) when the turn was asked; ``info["served"]``
    and ``info["reason"]`` are the step's verdict, true and ``None`` when either served."""
    out, info = relay(predictor, blocked, start, goal, first, cfg)
    if info["served"] or getattr(predictor, "symmetries", TURNS) >= TURNS:
        return out, info
    turned = predictor.with_symmetries(TURNS)
    again = turned.predict_view(blocked, start, goal)
    why = region_verdict(again.region, blocked, start, goal, cfg)[2]
    if why is None:
        union, tinfo = again, {"hops": [], "served": True, "reason": None}
    else:
        union, tinfo = relay(turned, blocked, start, goal, again, cfg)
    info["turned"] = {"orientations": TURNS, **tinfo, "first_reason": info["reason"]}
    if tinfo["served"]:
        info.update(served=True, reason=None)
        return union, info
    return out, info


def _asked_again(hops: int, back: bool) -> str:
    return f"asked again from {hops} cell{'s' if hops != 1 else ''} where its region ended" + (
        " and from the goal's side" if back else "")


def relay_note(relayed: dict[str, Any] | None) -> str:
    """What the summaries of ``plan`` and ``predict`` say about a :func:`turned_relay` (its ``info``); empty when
    nothing was asked."""
    if not relayed:
        return ""
    turned, note = relayed.get("turned"), ""
    if relayed["hops"] or "back" in relayed:
        first = turned["first_reason"] if turned else relayed["reason"]
        note = (f"; the companion, {_asked_again(len(relayed['hops']), 'back' in relayed)}, "
                + ("joined start and goal (its regions together served)" if relayed["served"] and not turned
                   else f"did not join them ({first})"))
    if turned:
        again = f", {_asked_again(len(turned['hops']), 'back' in turned)}," if turned["hops"] or "back" in turned else ""
        note += (f"; averaged over {turned['orientations']} orientations of the grid{again} it "
                 + ("served" if turned["served"] else f"did not serve either ({turned['reason']})"))
    return note
