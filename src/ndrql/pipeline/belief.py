"""A plan on a map the planner does not fully know: the belief a request carries, the two grids, the record.

A request may carry a :class:`~ndrql.maps.belief.Belief` (``build_request(hide=MASK)``, ``ndrql plan MAP
--hide MASK``; on a ROS map also ``unknown="free"``): the agent learns on the **true** map, while
everything decided before learning reads the **belief** only, its unknown pixels counted free:

- the grid's size (``size auto`` searches the belief), the start's and goal's cells and the check that
  they connect (:func:`plan_grids`);
- the planning grid the priors see (``GridSetup.belief``): the model's prediction and its judge, Eq. 7's
  threshold, IQL-BFS's exact distance, the fallback. ``predictions="oracle"`` alone is drawn from the true
  grid: it is the ceiling, a prediction that knows what is hidden.

The learning grid is the true map at the size the belief chose, with the same start and goal cells; when
the truth does not connect them at that size the plan stops with :class:`~ndrql.errors.NoPathError`.
Learned paths are checked on the true map. The JSON's ``belief`` says what was unknown and the optimum
of both grids (:func:`belief_record`).

On a ROS map, ``unknown="obstacle"`` (the default) keeps ``map_server``'s reading: unknown space is an
obstacle, for the planner and the agent alike. ``unknown="free"`` is Nav2's ``allow_unknown``: unknown
space is unknown to the planner (counted free) and, since the truth behind it is not known, **free for
the learning environment as well**: the plan then shows what a planner that drives into unknown space
learns, not what the world holds there.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any

import numpy as np

from ndrql.errors import NdrqlError, NoPathError, PointError
from ndrql.maps.belief import UNKNOWN_RULES, Belief, check_belief, read_mask
from ndrql.maps.grid import GridMap, PlanningGrid
from ndrql.maps.readers import YAML_SUFFIXES, read_ros_yaml
from ndrql.maps import sizing
from ndrql.maps.sizing import connected4
from ndrql.pipeline.problem import build_grid, inflated
from ndrql.pipeline.settings import PlanSettings
from ndrql.planning.runner import astar_length

#: What the JSON says of the learning environment on a ROS map read with ``unknown="free"``.
ROS_FREE_NOTE = ("the map's unknown space is free for the planner and for the learning environment: on a ROS map "
                 "the truth behind it is not known")


def _is_ros(source: Any) -> bool:
    return isinstance(source, (str, os.PathLike)) and os.fspath(source).lower().endswith(YAML_SUFFIXES)


def read_belief(source: Any, grid_map: GridMap, *, hide: Any = None, unknown: str | None = None, crop: bool = False,
                max_pixels: int | None = None) -> tuple[GridMap, Belief | None, str]:
    """The true map, the belief (``None``: the planner knows the map) and the rule for a ROS map's unknown space.

    ``hide``: a mask of the map's size (``.npy``, an image, an array; non-zero = unknown to the planner) or a
    whole :class:`Belief` (a study's outdated map: its own obstacles). ``unknown``: ``obstacle`` (default) or
    ``free`` for a ROS map's unknown space (module docstring); given for another map it is an error."""
    rule = "obstacle" if unknown is None else unknown
    if rule not in UNKNOWN_RULES:
        raise NdrqlError(f"unknown must be one of {', '.join(UNKNOWN_RULES)}, got {unknown!r}")
    if unknown is not None and not _is_ros(source):
        raise NdrqlError("--unknown says how a ROS map's unknown space counts; this map is not a ROS .yaml "
                         "(to hide part of any map from the planner, give --hide MASK)")
    masks = []
    if rule == "free":
        truth = read_ros_yaml(source, crop=crop, max_pixels=max_pixels, unknown_free=True)
        masks.append(grid_map.obstacles & ~truth.obstacles)
        grid_map = truth
    believed = grid_map.obstacles
    kind = "ros" if masks else "given"
    if isinstance(hide, Belief):
        if hide.shape != grid_map.shape:
            raise NdrqlError(f"the belief is {hide.shape[0]}x{hide.shape[1]} (rows x cols); the map is "
                             f"{grid_map.shape[0]}x{grid_map.shape[1]}")
        believed, kind = hide.obstacles, hide.kind
        masks.append(hide.unknown)
    elif hide is not None:
        masks.append(read_mask(hide, grid_map.shape))
    if not masks:
        return grid_map, None, rule
    return grid_map, Belief(believed, np.logical_or.reduce(masks), kind=kind), rule


def check_points_known(belief: Belief | None, start: tuple[int, int], goal: tuple[int, int]) -> None:
    """Refuse start or goal unknown to the planner, and a mask that hides every free pixel."""
    if belief is not None:
        check_belief(belief, start, goal)


def plan_grids(grid_map: GridMap, start: tuple[int, int], goal: tuple[int, int], settings: PlanSettings,
               belief: Belief | None = None):
    """``(learning grid, GridSetup)``: :func:`~ndrql.pipeline.problem.build_grid` on the map when nothing is
    hidden; else the grid size, cells and connectivity decided on the belief (unknown counted free), the
    learning grid the true map at that size, and ``GridSetup.belief`` the belief's grid on the same cells."""
    if belief is None:
        return build_grid(grid_map, start, goal, settings)
    seen = GridMap(belief.planner_obstacles("free"), resolution=grid_map.resolution, origin=grid_map.origin,
                   source=grid_map.source)
    bpg, bsetup = build_grid(seen, start, goal, settings)
    truth_check, radius_px = inflated(grid_map, settings)
    for name, p in (("start", start), ("goal", goal)):
        if truth_check[p]:
            raise PointError(f"{name} {p[0]},{p[1]} is within the robot radius of an obstacle of the true map")
    size = bsetup.size
    where = f"the {bpg.shape[0]}x{bpg.shape[1]} grid the belief chose (size {size})"
    try:
        if settings.grid == "area":
            tpg = PlanningGrid.from_map(truth_check, start, goal, size=size)
        else:
            tpg = sizing.safe_grid(truth_check, size, start, goal)
    except NoPathError:
        tpg = None
    if tpg is None or tpg.start == tpg.goal or not connected4(tpg.blocked, tpg.start, tpg.goal):
        raise NoPathError(f"start and goal connect on the belief map but not on the true map at {where}: what is "
                          f"hidden closes every way at this size (a finer --size may open it)")
    blocked = np.array(bpg.blocked, dtype=bool)
    blocked[tpg.start] = blocked[tpg.goal] = False  # the agent's cells; known to the planner (check_belief)
    prior_grid = dataclasses.replace(bpg, blocked=blocked, start=tpg.start, goal=tpg.goal, snapped=tpg.snapped)
    return tpg, dataclasses.replace(bsetup, check_map=truth_check, radius_px=radius_px, belief=prior_grid)


def belief_record(belief: Belief | None, rule: str, truth: GridMap, grid: PlanningGrid,
                  prior_grid: PlanningGrid | None) -> dict[str, Any]:
    """The JSON's ``belief``: kind, rule, unknown pixels and share of the true free space, the cells the belief
    has wrong, and the optimum (4-connected moves) on the true grid and on the belief's."""
    if belief is None:
        return {}
    out: dict[str, Any] = {"kind": belief.kind, "unknown_rule": rule, "unknown_px": int(belief.unknown.sum()),
                           "unknown_share": round(belief.unknown_share(truth.obstacles), 4),
                           "true_optimum": astar_length(grid.blocked, grid.start, grid.goal)}
    if prior_grid is not None:
        wrong = prior_grid.blocked != grid.blocked
        out["cells_wrong"] = {"blocked_believed_free": int((wrong & grid.blocked).sum()),
                              "free_believed_blocked": int((wrong & ~grid.blocked).sum())}
        out["belief_optimum"] = (astar_length(prior_grid.blocked, prior_grid.start, prior_grid.goal)
                                 if connected4(prior_grid.blocked, prior_grid.start, prior_grid.goal) else None)
    if belief.kind == "ros" and rule == "free":
        out["note"] = ROS_FREE_NOTE
    return out


def belief_lines(info: dict[str, Any]) -> list[str]:
    """What ``plan``'s summary says of a belief and of sensing (nothing when the planner knows the map)."""
    b = info.get("belief")
    if not b:
        return []
    seen = b.get("belief_optimum")
    share = f"{b['unknown_share']:.0%}" if b["unknown_share"] >= 0.1 else f"{b['unknown_share']:.1%}"
    lines = [f"belief ({b['kind']}): {share} of the free space unknown to the planner (counted free); "
             f"priors from the belief, learning on the map; optimum {b['true_optimum']} moves on the map, "
             + (f"{seen} on the belief" if seen is not None else "none on the belief")]
    if b.get("note"):
        lines.append(f"note: {b['note']}")
    s = info.get("sensing")
    if s:
        rec = [r["recomputes"] for r in s["runs"]]
        lines.append(f"sensing: radius {s['radius_cells']:g} cells, priors rebuilt every {s['every']} episode(s) while the "
                     f"map changes: {min(rec)}-{max(rec)} rebuilds per run, known cells "
                     f"{s['runs'][0]['known_start']:.0%} -> {max(r['known_end'] for r in s['runs']):.0%}")
    return lines


__all__ = ["ROS_FREE_NOTE", "belief_lines", "belief_record", "check_points_known", "plan_grids", "read_belief"]
