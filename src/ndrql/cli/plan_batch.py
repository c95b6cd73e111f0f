"""``ndrql plan MAP --scen FILE --all`` (or ``--index A:B``), and ``ndrql astar`` the same: every scenario
of a MovingAI ``.scen`` on one map.

One line per scenario and a summary against the ``.scen`` optimal lengths: the final path's octile
cost, the MovingAI measure, over the optimal octile length. ``--jsonl FILE`` appends one JSON record
per scenario as it finishes (fields: :data:`RECORD_FIELDS`, documented in docs/cli.md); run the same
command again and the scenarios already in the file are skipped (resume). A scenario that cannot be
planned (start and goal not connected at the robot's radius, in one cell, ...) is reported on its line
and in its record and does not stop the batch. A path that converged without collision but runs more
than :data:`LONG_RATIO` times the optimum, or crosses itself, is flagged (``long``, ``loop``), not ``ok``.
Warnings name their scenario (``scenario 12: start 40,7: ...``) and are kept in its record.
"""

from __future__ import annotations

import math
import time
import warnings
from contextlib import nullcontext
from pathlib import Path
from typing import Any, Callable, Sequence

from ndrql.api import build_request, read_map, run_request
from ndrql.errors import FallbackWarning, NdrqlError
from ndrql.io import json_text
from ndrql.io.jsonl import BatchLog
from ndrql.maps.lines import crosses_itself
from ndrql.maps.readers import read_movingai_scen
from ndrql.maps.scenarios import ScenarioWarning, scenario_doubts
from ndrql.pipeline.request import request_settings
from ndrql.pipeline.route import octile_cost
from ndrql.pipeline.shortest import search
from ndrql.planning.methods import get_method

#: The signature at the start of every ``--jsonl`` record (:class:`ndrql.io.jsonl.BatchLog`).
LOG_FORMAT = "ndrql-plan-batch/1"
#: A successful path whose octile cost is more than this many times the scenario's optimum is flagged ``long``.
LONG_RATIO = 1.25
#: The fields of a record, in order (docs/cli.md describes each; ``None`` where a field does not apply).
RECORD_FIELDS: tuple[str, ...] = (
    "format", "map", "scen", "method", "seed", "grid_rule", "size", "robot_radius", "scenario", "start", "goal",
    "optimal", "ran", "status", "success", "converged", "convergence_steps", "convergence_episode", "episodes",
    "total_steps", "expanded", "grid", "path_moves", "octile", "length", "ratio", "loop", "collisions", "warnings",
    "seconds", "path", "path_world", "requested", "fallback_reason", "error")
#: Fields a record has only when they apply (``format`` is :class:`BatchLog`'s, written first); the others are
#: always there, ``None`` where they do not apply.
OPTIONAL_FIELDS: tuple[str, ...] = ("format", "path_world", "requested", "fallback_reason", "error")
#: What a record's ``status`` says, in the order the checks run.
STATUSES: tuple[str, ...] = ("error", "no path", "collides", "not converged", "loop", "long", "ok")
#: What each field of a record means (docs/cli.md renders this table: tools/gen_cli_docs.py).
FIELD_DOCS: dict[str, str] = {
    "format": f"`{LOG_FORMAT}`: the record's signature",
    "map": "the map file as given", "scen": "the `.scen` file as given",
    "method": "the method asked for (`ndrql astar`: `A*` on the planning grid, `A*-octile` on the full map)",
    "seed": "the seed (`null` for A*)",
    "grid_rule": "`safe` or `area` (`null` for `A*-octile`)", "size": "the grid size setting, `auto` or N",
    "robot_radius": "as given (metres on maps with a resolution, else pixels)",
    "scenario": "the scenario's index in the `.scen` (0-based); the record's key when a batch resumes",
    "start": "start `[row, col]` in map pixels (the `.scen`'s y, x)", "goal": "goal `[row, col]` in map pixels",
    "optimal": "the `.scen`'s optimal octile length",
    "ran": "the method that ran (another than `method` when the fallback replaced it)",
    "status": f"`ok`, or the first that holds of: {', '.join(f'`{x}`' for x in STATUSES[:-1])} (`long`: a "
              f"successful path over {LONG_RATIO}x the optimum; `loop`: one that crosses itself)",
    "success": "converged, and the final path crosses no obstacle of the map inflated by the robot radius",
    "converged": "the greedy path was stable for W episodes (always `true` for A*)",
    "convergence_steps": "environment steps summed over the episodes up to convergence, the paper's measure "
                         "(`null` when not converged, and for A*)",
    "convergence_episode": "training episodes up to and including convergence (`null` as above)",
    "episodes": "training episodes run (`null` for A*)", "total_steps": "environment steps over all episodes run",
    "expanded": "nodes A* expanded (`null` for plan)",
    "grid": "the planning grid's `[rows, cols]` (`null` for `A*-octile`)",
    "path_moves": "moves of the path on its grid (planning-grid cells, or map pixels for `A*-octile`)",
    "octile": "the final path's octile cost in map pixels (each segment max(|dr|,|dc|) + (sqrt 2 - 1) min(|dr|,|dc|))",
    "length": "the final path's Euclidean length in map pixels",
    "ratio": "`octile` / `optimal`, the MovingAI measure (1 = optimal)",
    "loop": "whether the final path crosses itself", "collisions": "segments of the final path that cross an obstacle",
    "warnings": "warnings given while planning this scenario, each beginning `scenario K:` (points in map pixels)",
    "seconds": "wall time of this scenario",
    "path": "the final path `[[row, col], ...]` in map pixels", "path_world": "the final path as `[x, y, yaw]` poses "
    "in metres and radians (ROS maps only)",
    "requested": "the method asked for, when the fallback ran another", "fallback_reason": "why it did",
    "error": "why the scenario could not be planned (the record is kept; the batch goes on)",
}


def parse_indices(text: str | None, count: int, all_: bool) -> list[int]:
    """Scenario numbers from ``--index K`` / ``--index A:B`` (B excluded) / ``--all``, checked against ``count``."""
    if all_:
        if text is not None:
            raise NdrqlError("give either --all or --index, not both")
        return list(range(count))
    if text is None:
        return [0]
    head, sep, tail = str(text).partition(":")
    try:
        lo = int(head) if head.strip() else 0
        hi = (int(tail) if tail.strip() else count) if sep else lo + 1
    except ValueError:
        raise NdrqlError(f"--index must be K or A:B (scenario numbers), got {str(text)[:40]!r}") from None
    if not (0 <= lo < hi <= count):
        raise NdrqlError(f"--index {text} is outside the scenarios 0..{count - 1} of the file")
    return list(range(lo, hi))


def status(rec: dict[str, Any]) -> str:
    """The record's verdict (:data:`STATUSES`): the first that holds."""
    if "error" in rec:
        return "error"
    if rec.get("octile") is None:
        return "no path"
    if rec.get("collisions"):
        return "collides"
    if not rec.get("converged"):
        return "not converged"
    if rec.get("loop"):
        return "loop"
    if rec.get("ratio") is not None and rec["ratio"] > LONG_RATIO:
        return "long"
    return "ok"


def route_fields(route: Any, optimal: float) -> dict[str, Any]:
    """The final path's fields of a record: octile cost, length, ratio to ``optimal``, loop, collisions, points."""
    if route is None:
        return {"octile": None, "length": None, "ratio": None, "loop": None, "collisions": None}
    cost = octile_cost(route.pixels)
    out: dict[str, Any] = {
        "octile": round(cost, 4), "length": round(route.length, 4),
        "ratio": round(cost / optimal, 5) if optimal > 0 else None, "loop": crosses_itself(route.pixels),
        "collisions": len(route.final_collisions),
        "path": [[round(float(a), 3), round(float(b), 3)] for a, b in route.pixels]}
    if route.poses is not None:
        out["path_world"] = [[round(float(v), 4) for v in pose] for pose in route.poses]
    return out


def plan_fields(request: Any) -> dict[str, Any]:
    """Plan ``request`` (one method, one seed): the run's fields of a record."""
    report = run_request(request, workers=1)
    run = report.results[0]
    rec: dict[str, Any] = {
        "ran": run.method, "success": run.success, "converged": run.converged,
        "convergence_steps": run.convergence_steps, "convergence_episode": run.convergence_episode,
        "episodes": run.episodes, "total_steps": run.total_steps, "expanded": None,
        "grid": list(report.grid.shape), "path_moves": run.path_length, "route": run.route}
    if run.fallback_reason is not None:
        rec.update(requested=run.requested_method, fallback_reason=run.fallback_reason)
    return rec


def astar_fields(octile: bool) -> Callable[[Any], dict[str, Any]]:
    """Search a request with A* (:func:`ndrql.pipeline.shortest.search`): the run's fields of a record."""
    def fields(request: Any) -> dict[str, Any]:
        run = search(request, octile=octile)
        return {"ran": run.method, "success": run.success, "converged": True, "convergence_steps": None,
                "convergence_episode": None, "episodes": None, "total_steps": None, "expanded": run.expanded,
                "grid": None if run.grid is None else list(run.grid.shape),
                "path_moves": len(run.path) - 1, "route": run.route}
    return fields


def _line(rec: dict[str, Any]) -> str:
    head = f"scenario {rec['scenario']}: {tuple(rec['start'])} -> {tuple(rec['goal'])}, optimal {rec['optimal']:.2f}"
    state = rec.get("status") or status(rec)
    if state == "error":
        return f"{head}: ERROR {rec['error']}"
    if rec.get("octile") is None:
        return f"{head}: no path ({'converged' if rec['converged'] else 'not converged'})"
    shown = {"collides": "COLLIDES", "long": f"LONG (over {LONG_RATIO}x the optimum)", "loop": "LOOP (crosses itself)"}
    ratio = f"{rec['ratio']:.3f}x" if rec.get("ratio") is not None else "-"
    ran = f" ({rec['ran']} ran)" if rec.get("ran") not in (None, rec.get("method")) else ""
    steps = f", {rec['convergence_steps']:,} steps" if rec.get("convergence_steps") is not None else ""
    grid = f" on a {rec['grid'][0]}x{rec['grid'][1]} grid" if rec.get("grid") else " on the map"
    return (f"{head}; path {rec['octile']:.2f} ({ratio}){grid}, {shown.get(state, state)}{ran}{steps}, "
            f"{rec['seconds']:.2f} s")


def summary(records: Sequence[dict[str, Any]]) -> list[str]:
    """Counts per status and the distribution of octile cost / optimal over the scenarios with a path."""
    import numpy as np

    n = len(records)
    states = [r.get("status") or status(r) for r in records]
    ok = sum(bool(r.get("success")) for r in records)
    errors = states.count("error")
    collide = sum(bool(r.get("collisions")) for r in records)
    lines = [f"scenarios: {n}; success {ok}, path collides {collide}, not converged or no path {n - ok - collide - errors}, "
             f"errors {errors}"]
    flagged = {s: states.count(s) for s in ("long", "loop") if states.count(s)}
    if flagged:
        lines[0] += (f"; flagged among the successes: {', '.join(f'{k} {v}' for k, v in flagged.items())} "
                     f"(long: over {LONG_RATIO}x the optimum; loop: the path crosses itself)")
    ratios = np.asarray([r["ratio"] for r in records if r.get("ratio") is not None and r.get("success")])
    if ratios.size:
        q = np.quantile(ratios, [0.5, 0.9])
        lines.append(f"path octile cost / optimal over {ratios.size} successes: mean {ratios.mean():.3f}, median "
                     f"{q[0]:.3f}, 90% {q[1]:.3f}, max {ratios.max():.3f}; "
                     f"time {sum(r.get('seconds', 0.0) for r in records):.1f} s")
    steps = [r["convergence_steps"] for r in records if r.get("convergence_steps") is not None and r.get("success")]
    if steps:
        lines.append(f"convergence steps over {len(steps)} successes: median {float(np.median(steps)):,.0f}, "
                     f"mean {float(np.mean(steps)):,.0f}, max {max(steps):,}")
    return lines


def run_batch(map_path: str, scen_path: str, index: str | None, all_: bool, *, fields: dict[str, Any],
              jsonl: str | None, echo: Any, astar: str | None = None) -> int:
    """Run the chosen scenarios of ``scen_path`` on the map ``map_path``; print a line each and a summary.

    ``fields``: the keywords of :func:`~ndrql.pipeline.request.build_request` (one method, one seed): each
    scenario K is the request ``ndrql plan MAP --scen FILE:K`` makes, on the map read once. ``astar``:
    ``"A*"`` or ``"A*-octile"`` searches each request with A* (``ndrql astar``) instead of planning it."""
    fields = dict(fields)
    reader = {k: fields.pop(k) for k in ("invert", "threshold", "crop") if k in fields}
    settings = request_settings(**fields)
    grid_map = read_map(map_path, max_pixels=settings.max_map_pixels, **reader)
    scenarios = read_movingai_scen(scen_path)
    if not scenarios:
        raise NdrqlError(f"{scen_path} has no scenarios")
    indices = parse_indices(index, len(scenarios), all_)
    for doubt in scenario_doubts([scenarios[i] for i in indices], str(grid_map.source), scen_path, numbers=indices):
        warnings.warn(doubt, ScenarioWarning, stacklevel=1)
    for i in indices:
        s = scenarios[i]
        if grid_map.shape != (s.height, s.width):
            raise NdrqlError(f"scenario {i} of {scen_path} is for a {s.width}x{s.height} map (width x height), "
                             f"the map is {grid_map.width}x{grid_map.height}")
    if astar is None:
        method, seed = get_method(fields["methods"][0]).name, int(fields["seeds"][0])
        rule, size, solve = settings.grid, str(settings.grid_size), plan_fields
    else:
        octile = astar == "A*-octile"
        method, seed, solve = astar, None, astar_fields(octile)
        rule, size = (None, None) if octile else (settings.grid, str(settings.grid_size))
    key = {"map": str(grid_map.source), "scen": str(scen_path), "method": method, "seed": seed,
           "grid_rule": rule, "size": size, "robot_radius": settings.robot_radius}
    out = Path(jsonl) if jsonl else None
    with BatchLog(out, LOG_FORMAT, key, "scenario", _jsonl_text) if out is not None else nullcontext() as log:
        return _run(grid_map, scenarios, indices, log, key, scen_path, echo, fields, solve)


def _jsonl_text(record: dict[str, Any]) -> str:
    return json_text(record, indent=None, strict=False)


def _one(grid_map: Any, scen: Any, i: int, key: dict[str, Any], scen_path: str, fields: dict[str, Any],
         solve: Callable[[Any], dict[str, Any]]) -> dict[str, Any]:
    """Scenario ``i``'s record (:data:`RECORD_FIELDS` order); its warnings are named and kept in it."""
    t = time.perf_counter()
    rec: dict[str, Any] = {**key, "scenario": i, "start": list(scen.start), "goal": list(scen.goal),
                           "optimal": scen.optimal_length}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.simplefilter("ignore", ScenarioWarning)  # said once for the whole batch
        warnings.simplefilter("ignore", FallbackWarning)  # the line and the record say which method ran
        try:
            got = solve(build_request(grid_map, scen=scen_path, scen_index=i, **fields))
            route = got.pop("route")
            rec.update(got)
            rec.update(route_fields(route, scen.optimal_length))
        except NdrqlError as exc:
            rec.update(converged=False, success=False, error=" ".join(str(exc).split())[:300])
    said = [f"scenario {i}: {w.message}" for w in caught]
    for text in said:
        warnings.warn(text, UserWarning, stacklevel=1)
    rec.update(status=status(rec), warnings=said, seconds=round(time.perf_counter() - t, 3))
    return {k: rec.get(k) for k in RECORD_FIELDS if k in rec or k not in OPTIONAL_FIELDS}


def _run(grid_map: Any, scenarios: Any, indices: list[int], log: Any, key: dict[str, Any], scen_path: str, echo: Any,
         fields: dict[str, Any], solve: Callable[[Any], dict[str, Any]]) -> int:
    from tqdm import tqdm

    out = log.path if log is not None else None
    done = log.done if log is not None else {}
    records = [done[i] for i in indices if i in done]
    if records:
        echo(f"resuming: {len(records)} of {len(indices)} scenarios already in {out}")
    todo = [i for i in indices if i not in done]
    t0 = time.perf_counter()
    for i in tqdm(todo, desc="scenarios", unit="scen", disable=None, leave=False):
        rec = _one(grid_map, scenarios[i], i, key, scen_path, fields, solve)
        if log is not None:
            log.append(rec)
        records.append(rec)
        tqdm.write(_line(rec), file=_stream(echo))
    records.sort(key=lambda r: int(r["scenario"]))
    for line in summary(records):
        echo(line)
    if out is not None:
        echo(f"wrote {out} ({len(records)} records; {math.ceil(time.perf_counter() - t0)} s this run)")
    return 0


def _stream(echo: Any) -> Any:
    import sys

    return echo.keywords.get("file", sys.stdout) if hasattr(echo, "keywords") else sys.stdout
