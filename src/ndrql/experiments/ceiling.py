"""The ceiling: NDR-QL with the model's priors against NDR-QL with oracle priors, on the safe grid.

For each held-out map and planning-grid size ``n`` the planner solves the conservative grid
(:func:`ndrql.maps.safe.conservative_grid`). On it run, with the same seeds: QL, IQL, NDR-QL with the
model's region and guideline, and NDR-QL with the *oracle's* (an 8-connected shortest path of the grid
with line-of-sight shortcuts, drawn as the dataset draws its labels, :func:`ndrql.pipeline.sources.drawn_priors`: ``plan``'s exact source). The model's share
of the oracle's reduction is ``(1 - NDR/QL) / (1 - oracle/QL)`` on pooled steps, computed from the
same runs as the rows it divides. Runs that do not converge count with the steps they used.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ndrql.dataset.encodings import encode_input
from ndrql.dataset.render import PX_PER_CELL, connected_grid, from_model_output, input_side, to_model_input
from ndrql.experiments.stats import share_of_oracle
from ndrql.maps.astar import astar4
from ndrql.maps.grid import MODEL_SIDE, area_downscale
from ndrql.maps.problem import MapProblem
from ndrql.maps.safe import cell_size_px
from ndrql.maps.sizing import SIZE_LADDER
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.pipeline.predictions import predict_on_grid
from ndrql.pipeline.samples import Problem
from ndrql.pipeline.sources import drawn_priors
from ndrql.planning.runner import run_plan

Point = tuple[int, int]

#: Methods of a ceiling row, in order; the two NDR-QL rows differ only in where the priors come from.
ROWS = ("QL", "IQL", "NDR-QL (model)", "NDR-QL (oracle)")


@dataclass(frozen=True)
class GridCase(MapProblem):
    """A map problem (``obstacles``, ``start``, ``goal`` in map pixels) on its safe grid of ``n`` cells: the
    case a study runs the planners on. :func:`case_problem` makes it an experiment's
    :class:`~ndrql.pipeline.samples.Problem` (with the A* length and the priors)."""

    name: str
    group: str
    n: int
    blocked: np.ndarray
    """The safe grid (``True`` = blocked)."""
    start_cell: Point
    goal_cell: Point


def grid_case(name: str, group: str, obstacles: np.ndarray, start: Point, goal: Point, n: int,
              larger: tuple[int, ...] = ()) -> GridCase | None:
    """The safe-grid problem of a map at ``n`` cells (or at the first of ``larger`` on which it connects,
    like ``--size auto`` from ``n`` up), or ``None`` when start and goal connect on none of them."""
    for size in (n, *larger):
        placed = connected_grid(obstacles, start, goal, size)
        if placed is not None:
            blocked, start_cell, goal_cell = placed
            return GridCase(obstacles, start, goal, name=name, group=group, n=size, blocked=blocked,
                            start_cell=start_cell, goal_cell=goal_cell)
    return None


def case_problem(case: GridCase, split: str, index: int,
                 priors: tuple[np.ndarray | None, ...] = (None, None, None)) -> Problem:
    """``case`` as an experiment's problem named ``<split>-<index>`` (category: its group), with its A* length
    on the grid and ``priors`` (region, guideline and the goal distance per cell, each ``None`` when absent)."""
    opt = int(astar4(case.blocked, case.start_cell, case.goal_cell).moves)
    source = MapProblem(case.obstacles, tuple(case.start), tuple(case.goal))  # type: ignore[arg-type]
    region, guideline, distance = (*priors, None, None, None)[:3]
    return Problem(split, index, case.group, source, case.blocked, tuple(case.start_cell),  # type: ignore[arg-type]
                   tuple(case.goal_cell), opt, region, guideline, distance)  # type: ignore[arg-type]


#: The largest size :func:`larger_sizes` grows a grid of at most :data:`SMALL_GRID` cells to (the figures at
#: 50 and 100 cells were measured with it), and the largest it grows any larger grid to (the ladder's top).
SMALL_TOP, LARGE_TOP = 128, 512
#: Grids up to this many cells keep :data:`SMALL_TOP`.
SMALL_GRID = 100


def ladder_top(n: int) -> int:
    """The largest size a map that does not connect at ``n`` cells is retried on: ``min(2n, 128)`` up to
    :data:`SMALL_GRID` cells, ``min(2n, 512)`` above (128 would clamp a grid of 128 or more to itself)."""
    return min(2 * n, SMALL_TOP if n <= SMALL_GRID else LARGE_TOP)


def larger_sizes(n: int) -> tuple[int, ...]:
    """Sizes tried after ``n`` when a map does not connect at ``n``: the auto ladder up to :func:`ladder_top`."""
    return tuple(s for s in SIZE_LADDER if n < s <= ladder_top(n))


def oracle_priors(case: GridCase, distance: bool = False) -> tuple[np.ndarray, ...]:
    """Region and guideline of the oracle on the grid, drawn as ``plan``'s exact source draws them
    (:func:`ndrql.pipeline.sources.drawn_priors`: on a map the planner knows, this row is what ``plan`` runs); with
    ``distance`` also the exact goal distance per cell (4-connected moves; cells that cannot reach the goal get the
    largest distance plus their Manhattan distance), the perfect version of a distance head's output."""
    out = drawn_priors("oracle", case.blocked, case.start_cell, case.goal_cell, None)
    return (out.region, out.guideline) + ((out.distance,) if distance else ())


def model_priors(predictor, mode: str, case: GridCase, seen: dict | None = None) -> tuple[np.ndarray, ...]:
    """Region and guideline of the model on the grid, for a model trained on input ``mode``, and its goal
    distance per cell (cells) when it has a distance head.

    ``grid``: the safe grid at 4 px per cell; ``map``: the map at ``4n + 1`` px; ``map201``: the map at
    201 px whatever the grid (the input of the paper's model before multi-scale training). ``seen``: filled
    with what a grid-mode model saw (:func:`~ndrql.pipeline.predictions.predict_on_grid`'s ``info``).
    """
    if mode == "grid":
        r, gl, info, d = predict_on_grid(predictor, case.blocked, case.start_cell, case.goal_cell)
        if seen is not None:
            seen.update(info)
        return (r, gl) if d is None else (r, gl, d)
    side = MODEL_SIDE if mode == "map201" else input_side("map", case.n)
    img, s, g, scale = to_model_input(case.obstacles, case.start, case.goal, side)
    r, gl = predictor.predict_batch(encode_input(img, s, g, predictor.encoding)[None])
    shape = case.obstacles.shape
    region = from_model_output(r[0], shape, scale)
    guide = from_model_output(gl[0], shape, scale)
    cell = cell_size_px(shape, case.n)
    hh, ww = case.blocked.shape
    pad = np.zeros((int(round(hh * cell)), int(round(ww * cell))))
    out = []
    for a in (region, guide):
        p = pad.copy()
        p[:shape[0], :shape[1]] = a[:p.shape[0], :p.shape[1]]
        out.append(area_downscale(p, (hh, ww)))
    return out[0], out[1]


@dataclass
class CaseResult:
    """Steps (converged or not: the steps used) and path ratios per row and seed."""

    case: str
    group: str
    n: int
    steps: dict[str, list[int]] = field(default_factory=dict)
    ratio: dict[str, list[float]] = field(default_factory=dict)
    threshold: dict[str, float | None] = field(default_factory=dict)


def prior_arrays(pr) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None]:
    """``(region, guideline, distance)`` of a row's priors (two or three arrays, or ``None`` for QL/IQL);
    ``None`` for what is missing."""
    if pr is None:
        return None, None, None
    arrays = [np.asarray(a) for a in pr]
    return arrays[0], arrays[1], arrays[2] if len(arrays) > 2 else None


def run_case(case: GridCase, priors: dict[str, tuple[np.ndarray, ...] | None], seeds: list[int],
             config: QLConfig = QLConfig(), prior_config: PriorConfig = PriorConfig()) -> CaseResult:
    """Run each row in ``priors`` (row name -> region, guideline and optionally the goal distance on the
    grid, ``None`` for QL/IQL)."""
    out = CaseResult(case.name, case.group, case.n)
    for row, pr in priors.items():
        method = row.split(" ")[0]
        region, guide, dist = prior_arrays(pr)
        runs = [run_plan(case.blocked, case.start_cell, case.goal_cell, method, s, config, prior_config, region, guide,
                         distance=dist) for s in seeds]
        out.steps[row] = [int(r.convergence_steps if r.converged else r.total_steps) for r in runs]
        out.ratio[row] = [float(r.length_ratio) for r in runs if r.converged and r.length_ratio is not None]
        out.threshold[row] = runs[0].threshold if hasattr(runs[0], "threshold") else None
    return out


def pooled(results: list[CaseResult], row: str) -> float:
    return float(sum(sum(r.steps[row]) for r in results if row in r.steps))


def share(results: list[CaseResult], model_row: str = "NDR-QL (model)", oracle_row: str = "NDR-QL (oracle)") -> float:
    """``(1 - NDR/QL) / (1 - oracle/QL)`` on pooled steps of the same runs (:func:`~ndrql.experiments.stats.share_of_oracle`)."""
    return share_of_oracle(*([pooled(results, row)] for row in (model_row, oracle_row, "QL")))


def summary_rows(results: list[CaseResult], rows: tuple[str, ...]) -> list[dict]:
    """Per row: pooled steps vs QL, mean path/A*, share of maps where it beats IQL (per-map mean steps)."""
    ql = pooled(results, "QL")
    out = []
    for row in rows:
        if not any(row in r.steps for r in results):
            continue
        ratios = [x for r in results for x in r.ratio.get(row, [])]
        beats = [np.mean(r.steps[row]) < np.mean(r.steps["IQL"]) for r in results if row in r.steps and "IQL" in r.steps]
        out.append({"row": row, "vs_ql": pooled(results, row) / ql - 1, "path_ratio": float(np.mean(ratios)) if ratios else float("nan"),
                    "beats_iql": float(np.mean(beats)) if beats else float("nan"), "maps": len(results)})
    return out
