"""Revealed as it moves: Q-learning whose priors are recomputed as the robot's sensors reveal the map.

The agent learns on the true planning grid; the planner starts from a belief grid (known cells as the
truth, unknown cells counted free). Learning runs one episode per call of the compiled kernel (unchanged)
with the Q-table carried over (:func:`~ndrql.planning.runner.run_plan` with ``keep_q``), and the
convergence test of a plain run (the same greedy path ``window`` episodes running,
:func:`ndrql.planning.rules.greedy_streak`) is kept across the calls. After each episode the cells the
agent stood on (the rows of the Q-table it updated) sense every cell within ``radius`` cells by line of
sight on the true grid (:func:`ndrql.synth.masks.visible_from`); what they reveal enters the belief.
Every :attr:`SenseConfig.every` episodes, when something new was revealed, the priors are rebuilt on the
belief and the Q-table keeps what was learned: ``Q <- Q + (Q0_new - Q0_old)`` (each entry moves by the
change of its prior). Episode ``k``'s seed is derived from the run's seed and ``k``, so a run depends
only on its inputs and seed. The priors cannot change within an episode (that needs a kernel that senses
per step).
"""

from __future__ import annotations

import dataclasses
import hashlib
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ndrql.planning.config import QLConfig
from ndrql.errors import NdrqlError
from ndrql.maps.belief import unknown_cells  # noqa: F401  (its home; re-exported here)
from ndrql.maps.grid import PlanningGrid
from ndrql.pipeline.sources import Repredict, belief_floor
from ndrql.planning.methods import Method, Priors, build_priors
from ndrql.planning.results import PlanResult
from ndrql.planning.runner import astar_length, run_plan
from ndrql.synth.masks import ray_offsets, visible_from

Cell = tuple[int, int]
#: Episodes between recomputations by default: after every episode, the best of 1, 2, 5, 20 and 100 on the
#: development set partial-dev (studies/partial/README.md, "Revealed as it moves").
DEFAULT_EVERY = 1
#: What a rebuild of the priors does to the Q-table (:attr:`SenseConfig.carry`).
CARRY = ("shift", "reset", "keep")
#: Priors of a method on a belief grid (``True`` = blocked) and the cells known in it.
PriorsOn = Callable[[np.ndarray, np.ndarray], Priors]


@dataclass(frozen=True)
class SenseConfig:
    """How the robot senses and how often the planner recomputes its priors."""

    radius: float
    """Sensing radius in planning cells (line of sight on the true grid)."""
    every: int = 20
    """Episodes between rebuilds of the priors (when something new was revealed since the last)."""
    carry: str = "shift"
    """What a rebuild does to the Q-table: ``shift`` (each entry moves by the change of its prior), ``reset``
    (the new priors, what was learned dropped) or ``keep`` (the Q-table as learned; only the rewards change)."""
    max_chunks: int = 10_000
    """Most rebuild intervals of a run (``max_chunks x every`` episodes; the cap of the :class:`QLConfig` holds too)."""
    predict_again: bool = False
    """``True``: at each rebuild a belief model predicts again on the grown belief for the NDR methods (one forward
    pass per new belief). ``False`` (the default): the first prediction is kept and only its distance's floor
    follows the belief. Predicting again took 0.979x the steps (95% 0.954 .. 1.003) on a development set, not
    clearly fewer: an option of the API (studies/partial/README.md, "Predicting again as the robot senses")."""

    def __post_init__(self) -> None:
        if not self.radius > 0:
            raise ValueError(f"the sensing radius must be positive, got {self.radius}")
        if self.every < 1 or self.max_chunks < 1:
            raise ValueError("every and max_chunks must be at least 1")
        if self.carry not in CARRY:
            raise ValueError(f"carry must be one of {', '.join(CARRY)}, got {self.carry!r}")


@dataclass
class SensedRun:
    """One run revealed as it moves: steps as a plain run counts them, and what happened per chunk."""

    converged: bool
    steps: int
    """Steps to convergence (all steps when it did not converge)."""
    episodes: int
    path_length: int | None
    astar_length: int
    recomputes: int = 0
    """How many times the priors were rebuilt."""
    known_share: list[float] = field(default_factory=list)
    """Share of the grid's cells known after each episode."""
    result: PlanResult | None = field(default=None, repr=False)
    """The run as a :class:`PlanResult`: the converged path, the steps and episodes of all calls."""


def sense_config(radius: float | None, every: int | None, has_belief: bool) -> SenseConfig | None:
    """The request's sensing (``None`` without ``radius``); :class:`NdrqlError` for a radius that is not a positive
    number, an interval below 1, an interval without a radius, or sensing on a map the planner knows."""
    if radius is None:
        if every is not None:
            raise NdrqlError("--sense-every needs --sense R (the sensing radius in planning cells)")
        return None
    if isinstance(radius, bool) or not isinstance(radius, (int, float)) or not 0 < float(radius) < float("inf"):
        raise NdrqlError(f"--sense must be a positive number of planning cells, got {str(radius)[:40]!r}")
    if every is not None and (isinstance(every, bool) or not isinstance(every, int) or every < 1):
        raise NdrqlError(f"--sense-every must be a whole number of episodes >= 1, got {str(every)[:40]!r}")
    if not has_belief:
        raise NdrqlError("--sense reveals what the planner does not know: give --hide MASK (or --unknown free on a "
                         "ROS map)")
    return SenseConfig(radius=float(radius), every=DEFAULT_EVERY if every is None else int(every))


def chunk_seed(seed: int, chunk: int) -> int:
    """The kernel's seed for episode (call) ``chunk`` of a run with ``seed`` (63 bits)."""
    return int(np.random.SeedSequence([int(seed), int(chunk)]).generate_state(1, np.uint64)[0] >> np.uint64(1))


def sense(truth: np.ndarray, cells: np.ndarray, radius: float) -> np.ndarray:
    """Every cell within ``radius`` of one of ``cells`` (``(N, 2)``) with a line of sight on ``truth``."""
    seen = np.zeros(truth.shape, dtype=bool)
    rays = ray_offsets(radius)
    for r, c in np.asarray(cells, dtype=np.int64).reshape(-1, 2):
        seen |= visible_from(truth, (r, c), radius, rays)
    return seen


def run_sensed(truth: np.ndarray, belief: np.ndarray, known: np.ndarray, start: Cell, goal: Cell, method: str,
               seed: int, config: QLConfig, priors_on: PriorsOn, sensing: SenseConfig) -> SensedRun:
    """Q-learning of ``method`` on ``truth`` (blocked cells) with priors rebuilt by ``priors_on`` on the belief
    as it grows (module docstring). ``belief``: the blocked cells believed at the start (unknown cells free);
    ``known``: the cells known at the start (start and goal at least)."""
    truth = np.asarray(truth, dtype=bool)
    known = np.asarray(known, dtype=bool) | sense(truth, np.array([start]), sensing.radius)
    belief = np.where(known, truth, np.asarray(belief, dtype=bool))
    pri = priors_on(belief, known)
    q = np.array(pri.q0, dtype=np.float64, copy=True)
    opt = astar_length(truth, start, goal)
    out = SensedRun(converged=False, steps=0, episodes=0, path_length=None, astar_length=opt)
    w = truth.shape[1]
    viewed = np.zeros(truth.shape, dtype=bool)  # cells already sensed from: they reveal nothing new
    viewed[start] = True
    one = dataclasses.replace(config, max_episodes=1, window=1)  # one episode a call; converged = rollout reached
    streak, best, pending, since = 0, None, False, 0
    res = None
    for k in range(min(int(config.max_episodes), sensing.max_chunks * sensing.every)):
        res = run_plan(truth, start, goal, method, chunk_seed(seed, k), one, priors=Priors(pri.r_c, q, pri.threshold),
                       keep_q=True, astar=opt)
        out.episodes += 1
        out.steps += int(res.total_steps)
        if res.converged:  # rules.greedy_streak across calls: the same greedy path `window` episodes running
            streak = streak + 1 if res.path == best else 1
            best = res.path
        else:
            streak = 0
        if streak >= config.window:
            out.converged, out.path_length = True, res.path_length
            break
        stood = np.flatnonzero(np.any(res.q_table != q, axis=1) & ~viewed.ravel())
        viewed.flat[stood] = True
        q = res.q_table
        new = sense(truth, np.stack([stood // w, stood % w], axis=1), sensing.radius) & ~known
        if new.any():
            known |= new
            belief[new] = truth[new]
            pending = True
        out.known_share.append(float(known.mean()))
        since += 1
        if pending and since >= sensing.every:
            fresh = priors_on(belief, known)
            if sensing.carry == "shift":
                q = np.ascontiguousarray(q + (fresh.q0 - pri.q0))
            elif sensing.carry == "reset":
                q = np.array(fresh.q0, dtype=np.float64, copy=True)
            pri, pending, since = fresh, False, 0
            out.recomputes += 1
    if res is not None:
        out.result = dataclasses.replace(
            res, seed=int(seed), episodes=out.episodes, total_steps=out.steps, q_table=None,
            converged=out.converged, convergence_episode=out.episodes if out.converged else None,
            convergence_steps=out.steps if out.converged else None, path=res.path if res.converged else None,
            path_length=res.path_length if res.converged else None,
            length_ratio=res.length_ratio if res.converged else None)
    return out


def learn_sensed(grid: PlanningGrid, belief: PlanningGrid, unknown_px: np.ndarray, methods: list[Method],
                 seeds: list[int], consts: Callable, region: np.ndarray | None, guideline: np.ndarray | None,
                 distance: np.ndarray | None, sensing: SenseConfig, record: dict | None = None,
                 repredict: Repredict | None = None) -> list[PlanResult]:
    """Every method with every seed (methods outer) revealed as it moves: the learning ``grid`` is the truth, the
    priors start on ``belief`` (a :class:`PlanningGrid` on the same cells) and are rebuilt as the robot senses the
    cells it stands on; Eq. 6's mask stays off (:data:`ndrql.pipeline.prior_stage.BELIEF_MASK`) and the distance is
    floored at each belief's BFS distance (:func:`~ndrql.pipeline.sources.belief_floor`). The NDR methods' region,
    guideline and distance are predicted again on each grown belief by ``repredict`` (a belief model,
    :func:`~ndrql.pipeline.sources.belief_predictor`) when :attr:`SenseConfig.predict_again`, else the first
    prediction (``region``, ``guideline``, ``distance``) is kept. ``record`` receives ``sensing``: radius,
    recomputation interval, the model's forward passes and, per run, the recomputations and the known share."""
    known = ~unknown_cells(unknown_px, grid)
    known[grid.start] = known[grid.goal] = True
    again = _Again(repredict) if sensing.predict_again and repredict is not None else None
    out, runs = [], []
    for m in methods:
        ql, pc = consts(m.name)
        if again is not None and m.needs_ndr:
            def priors_on(b: np.ndarray, kn: np.ndarray, m: Method = m, pc=pc) -> Priors:
                r, g, d = again(b, kn)
                return build_priors(m, b, grid.start, grid.goal, r, g, pc, belief_floor(d, b, grid.goal), None)
        else:
            priors_on = lambda b, kn, m=m, pc=pc: build_priors(  # noqa: E731
                m, b, grid.start, grid.goal, region, guideline, pc, belief_floor(distance, b, grid.goal), None)
        for seed in seeds:
            r = run_sensed(grid.blocked, belief.blocked, known, grid.start, grid.goal, m.name, seed, ql, priors_on, sensing)
            out.append(r.result)
            runs.append({"method": m.name, "seed": int(seed), "recomputes": r.recomputes,
                         "known_start": round(float(known.mean()), 4),
                         "known_end": round(r.known_share[-1], 4) if r.known_share else round(float(known.mean()), 4)})
    if record is not None:
        record["sensing"] = {"radius_cells": sensing.radius, "every": sensing.every, "carry": sensing.carry,
                             "predict_again": again is not None, "predictions": 0 if again is None else again.calls,
                             "runs": runs}
    return out


class _Again:
    """A belief model's predictions on grown beliefs, the last few kept (every seed starts from the same belief)."""

    KEEP = 8

    def __init__(self, repredict: Repredict):
        self.repredict, self.calls, self.kept = repredict, 0, {}

    def __call__(self, blocked: np.ndarray, known: np.ndarray):
        key = hashlib.sha256(np.packbits(blocked).tobytes() + np.packbits(known).tobytes()).digest()
        if key not in self.kept:
            if len(self.kept) >= self.KEEP:
                self.kept.pop(next(iter(self.kept)))
            self.kept[key] = self.repredict(blocked, ~known)
            self.calls += 1
        return self.kept[key]


__all__ = ["DEFAULT_EVERY", "PriorsOn", "SenseConfig", "SensedRun", "chunk_seed", "learn_sensed", "run_sensed", "sense",
           "sense_config", "unknown_cells"]
