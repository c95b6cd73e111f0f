"""The propagating head asked where everything else failed on a large grid
(docs/large-maps.md#a-propagating-head-where-everything-else-fails-rule-written-2026-11-27-before-its-runs).

Above 128 cells, :func:`~ndrql.pipeline.predictions.predict_on_grid` asks the companion, then the base model, then
relays the companion and averages it over four orientations (:func:`~ndrql.pipeline.relay.turned_relay`). Where all
of that still leaves no region that can guide planning, :func:`propagated` asks the shipped propagating head
(:mod:`ndrql.model.propagation`): a small recurrent network that carries "on a shortest route" along the free
cells of the grid, one or two cells per iteration. Its probabilities become the region and the guideline when
its region passes the same test (:func:`~ndrql.pipeline.fallback.region_verdict`); the companion's distance is
kept. Otherwise nothing changes. Its cost is one pass per cell of the grid's side (about a second at 256 cells).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ndrql.model import propagation
from ndrql.pipeline.fallback import region_verdict

Point = tuple[int, int]


def propagated(predictor: Any, blocked: np.ndarray, start: Point, goal: Point, first: Any, cfg: Any
               ) -> tuple[Any, dict[str, Any] | None]:
    """``first`` (a prediction whose region cannot guide planning) or, where the shipped head's region can,
    ``first`` with the head's probabilities as region and guideline. ``info``: ``{"iterations", "graph_sha256" (the
    head's graph, 16 hex), "served", "reason"}`` (``reason`` why the head's region cannot guide planning either, else
    None), or None when no head is shipped (nothing was asked)."""
    if not propagation.available():
        return first, None
    prob = propagation.propagate(blocked, start, goal, getattr(predictor, "threads", 0))
    why = region_verdict(prob, blocked, start, goal, cfg)[2]
    record = propagation.read_record() or {}
    info = {"iterations": propagation.iterations(np.shape(blocked), int(record.get("chunk", 1))),
            "graph_sha256": str(record.get("onnx_sha256", ""))[:16], "served": why is None, "reason": why}
    if why is not None:
        return first, info
    guide = None if first.guideline is None else prob
    return replace(first, region=prob, guideline=guide), info


def propagated_note(info: dict[str, Any] | None) -> str:
    """What the summaries of ``plan`` and ``predict`` say about :func:`propagated` (its ``info``); empty when
    nothing was asked."""
    if not info:
        return ""
    told = "served" if info["served"] else f"did not serve either ({info['reason']})"
    return f"; the propagating head ({info['iterations']} iterations) {told}"
