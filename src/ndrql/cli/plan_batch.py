"""``ndrql plan MAP --scen FILE --all`` (or ``--index A:B``): every scenario of a MovingAI ``.scen`` on one map.

One line per scenario and a summary against the ``.scen`` optimal lengths: the final (smoothed) path's
octile cost, the MovingAI measure, over the optimal octile length. ``--jsonl FILE`` appends one JSON
record per scenario as it finishes; run the same command again and the scenarios already in the file
are skipped (resume). A scenario that cannot be planned (start and goal not connected at the robot's
radius, in one cell, ...) is reported on its line and in its record and does not stop the batch.
"""

from __future__ import annotations

import math
import time
import warnings
from contextlib import nullcontext
from pathlib import Path
from typing import Any, Sequence

from ndrql.api import build_request, read_map, run_request
from ndrql.errors import NdrqlError
from ndrql.io import json_text
from ndrql.io.jsonl import BatchLog
from ndrql.maps.readers import read_movingai_scen
from ndrql.pipeline.request import request_settings
from ndrql.maps.scenarios import scenario_doubts
from ndrql.pipeline.route import octile_cost
from ndrql.planning.methods import get_method

#: The signature at the start of every ``--jsonl`` record (:class:`ndrql.io.jsonl.BatchLog`).
LOG_FORMAT = "ndrql-plan-batch/1"


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


def _record(index: int, scen: Any, key: dict[str, Any], report: Any, seconds: float) -> dict[str, Any]:
    run = report.results[0]
    rec: dict[str, Any] = {**key, "scenario": index, "start": list(scen.start), "goal": list(scen.goal),
                           "optimal": scen.optimal_length, "ran": run.method, "converged": run.converged,
                           "success": run.success,
                           "grid": list(report.grid.shape), "seconds": round(seconds, 3)}
    if run.route is not None:
        cost = octile_cost(run.route.pixels)
        rec.update(octile=round(cost, 4), length=round(run.route.length, 4),
                   ratio=round(cost / scen.optimal_length, 5) if scen.optimal_length > 0 else None,
                   collisions=len(run.route.final_collisions),
                   path=[[round(float(a), 3), round(float(b), 3)] for a, b in run.route.pixels])
        if run.route.poses is not None:
            rec["path_world"] = [[round(float(v), 4) for v in pose] for pose in run.route.poses]
    if run.fallback_reason is not None:
        rec.update(requested=run.requested_method, fallback_reason=run.fallback_reason)
    return rec


def _line(rec: dict[str, Any]) -> str:
    head = f"scenario {rec['scenario']}: {tuple(rec['start'])} -> {tuple(rec['goal'])}, optimal {rec['optimal']:.2f}"
    if "error" in rec:
        return f"{head}: ERROR {rec['error']}"
    if "octile" not in rec:
        return f"{head}: no path ({'converged' if rec['converged'] else 'not converged'})"
    state = "ok" if rec["success"] else ("COLLIDES" if rec.get("collisions") else "not converged")
    ratio = f"{rec['ratio']:.3f}x" if rec.get("ratio") is not None else "-"
    ran = f" ({rec['ran']} ran)" if rec.get("ran") not in (None, rec.get("method")) else ""
    return (f"{head}; path {rec['octile']:.2f} ({ratio}) on a {rec['grid'][0]}x{rec['grid'][1]} grid, {state}{ran}, "
            f"{rec['seconds']:.2f} s")


def summary(records: Sequence[dict[str, Any]]) -> list[str]:
    """Counts and the distribution of octile cost / optimal over the scenarios with a path."""
    import numpy as np

    n = len(records)
    ok = sum(bool(r.get("success")) for r in records)
    errors = sum("error" in r for r in records)
    collide = sum(bool(r.get("collisions")) for r in records)
    ratios = np.asarray([r["ratio"] for r in records if r.get("ratio") is not None and r.get("success")])
    lines = [f"scenarios: {n}; success {ok}, path collides {collide}, not converged or no path {n - ok - collide - errors}, "
             f"errors {errors}"]
    if ratios.size:
        q = np.quantile(ratios, [0.5, 0.9])
        lines.append(f"path octile cost / optimal over {ratios.size} successes: mean {ratios.mean():.3f}, median "
                     f"{q[0]:.3f}, 90% {q[1]:.3f}, max {ratios.max():.3f}; "
                     f"time {sum(r.get('seconds', 0.0) for r in records):.1f} s")
    return lines


def run_batch(map_path: str, scen_path: str, index: str | None, all_: bool, *, fields: dict[str, Any],
              jsonl: str | None, echo: Any) -> int:
    """Run the chosen scenarios of ``scen_path`` on the map ``map_path``; print a line each and a summary.

    ``fields``: the keywords of :func:`~ndrql.pipeline.request.build_request` (one method, one seed): each
    scenario K is the request ``ndrql plan MAP --scen FILE:K`` makes, on the map read once."""
    fields = dict(fields)
    reader = {k: fields.pop(k) for k in ("invert", "threshold", "crop") if k in fields}
    settings = request_settings(**fields)
    grid_map = read_map(map_path, max_pixels=settings.max_map_pixels, **reader)
    method, seed = get_method(fields["methods"][0]).name, int(fields["seeds"][0])
    scenarios = read_movingai_scen(scen_path)
    if not scenarios:
        raise NdrqlError(f"{scen_path} has no scenarios")
    indices = parse_indices(index, len(scenarios), all_)
    for doubt in scenario_doubts([scenarios[i] for i in indices], str(grid_map.source), scen_path):
        warnings.warn(doubt, stacklevel=1)
    for i in indices:
        s = scenarios[i]
        if grid_map.shape != (s.height, s.width):
            raise NdrqlError(f"scenario {i} of {scen_path} is for a {s.width}x{s.height} map (width x height), "
                             f"the map is {grid_map.width}x{grid_map.height}")
    key = {"map": str(grid_map.source), "scen": str(scen_path), "method": method, "seed": seed,
           "grid_rule": settings.grid, "size": str(settings.grid_size), "robot_radius": settings.robot_radius}
    out = Path(jsonl) if jsonl else None
    with BatchLog(out, LOG_FORMAT, key, "scenario", _jsonl_text) if out is not None else nullcontext() as log:
        return _run(grid_map, scenarios, indices, log, key, scen_path, echo, fields)


def _jsonl_text(record: dict[str, Any]) -> str:
    return json_text(record, indent=None, strict=False)


def _run(grid_map: Any, scenarios: Any, indices: list[int], log: Any, key: dict[str, Any], scen_path: str, echo: Any,
         fields: dict[str, Any]) -> int:
    from tqdm import tqdm

    out = log.path if log is not None else None
    done = log.done if log is not None else {}
    records = [done[i] for i in indices if i in done]
    if records:
        echo(f"resuming: {len(records)} of {len(indices)} scenarios already in {out}")
    todo = [i for i in indices if i not in done]
    t0 = time.perf_counter()
    for i in tqdm(todo, desc="scenarios", unit="scen", disable=None, leave=False):
        s = scenarios[i]
        t = time.perf_counter()
        try:
            request = build_request(grid_map, scen=scen_path, scen_index=i, **fields)
            report = run_request(request, workers=1)
            rec = _record(i, s, key, report, time.perf_counter() - t)
        except NdrqlError as exc:
            rec = {**key, "scenario": i, "start": list(s.start), "goal": list(s.goal), "optimal": s.optimal_length,
                   "converged": False, "success": False, "error": " ".join(str(exc).split())[:300],
                   "seconds": round(time.perf_counter() - t, 3)}
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
