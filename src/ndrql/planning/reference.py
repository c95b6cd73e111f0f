"""Q-learning in numpy and a Python loop: the readable twin of :mod:`ndrql.planning.kernel`.

Written the way one would write it by hand (a numpy Q-table, ``np.argmax``, a loop per step), with
the same rules (:func:`ndrql.planning.rules.step`, :func:`~ndrql.planning.rules.greedy_streak`) and the
same random stream (:mod:`ndrql.planning.rng`), so for the same inputs and seed it makes exactly the
same run as the compiled kernel. Tests use it to check the kernel; ``benchmarks/qlearning_speed.py``
times both. It is a few hundred times slower than the kernel: use it only on small runs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ndrql.planning import rng, rules
from ndrql.planning.config import QLConfig


@dataclass
class ReferenceRun:
    """Output of :func:`train`, same meaning as the kernel's tuple."""

    q: np.ndarray
    steps: list[int]
    returns: list[float]
    success: list[bool]
    greedy_length: list[int]
    convergence_episode: int
    convergence_steps: int
    path: list[int] | None


def greedy_rollout(q: np.ndarray, nxt: np.ndarray, start: int, goal: int) -> list[int] | None:
    """The convergence rollout (docs/method.md): argmax with lowest-index ties; ``None`` on a revisit or after ``cells`` moves."""
    path = [start]
    seen = {start}
    s = start
    for _ in range(nxt.shape[0]):
        a = int(np.argmax(q[s]))
        s2 = int(nxt[s, a])
        if s2 in seen:  # includes a blocked move (s2 == s)
            return None
        path.append(s2)
        if s2 == goal:
            return path
        seen.add(s2)
        s = s2
    return None


def train(
    blocked: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    r_c: np.ndarray,
    q0: np.ndarray,
    seed: int,
    config: QLConfig = QLConfig(),
) -> ReferenceRun:
    """Q-learning per docs/method.md on ``blocked`` (bool (H, W)) from ``q0`` ((H*W, 4)) with ``seed``."""
    blocked = np.asarray(blocked, dtype=bool)
    h, w = blocked.shape
    cells = h * w
    nxt = rules.next_table(blocked)
    r_flat = np.asarray(r_c, dtype=np.float64).ravel()
    q = np.array(q0, dtype=np.float64, copy=True)
    s0 = rules.cell_index(start, w)
    g = rules.cell_index(goal, w)
    state = rng.seed_state(seed)
    thr = rng.eps_threshold(config.epsilon)
    max_steps = config.steps_cap(cells)
    visited = np.zeros(cells, dtype=np.int64)
    out = ReferenceRun(q, [], [], [], [], -1, -1, None)
    best: list[int] = []
    streak = 0
    total = 0
    for ep in range(config.max_episodes):
        mark = ep + 1
        visited[s0] = mark
        s = s0
        ret = 0.0
        n = 0
        reached = False
        while n < max_steps:
            u = rng.next_u64(state)
            if (u >> 32) < thr:
                candidates = np.arange(4)
            else:
                candidates = np.flatnonzero(q[s] == q[s].max())
            a = int(candidates[rng.pick(u, len(candidates))])
            s2, r, outcome = rules.step(
                nxt, g, r_flat, visited, mark, s, a, config.reward_collision, config.reward_goal, config.reward_revisit
            )
            n += 1
            ret += r
            rules.q_update(q, s, a, r, s2, outcome == rules.GOAL, config.alpha, config.gamma)
            if outcome == rules.GOAL:
                reached = True
                break
            s = int(s2)
        total += n
        out.steps.append(n)
        out.returns.append(ret)
        out.success.append(reached)
        path = greedy_rollout(q, nxt, s0, g)
        length = len(path) - 1 if path is not None else -1
        out.greedy_length.append(length)
        streak = rules.greedy_streak(streak, path, length, best, len(best) - 1)
        if path is not None:
            best = path
        if streak >= config.window:
            out.convergence_episode = ep
            out.convergence_steps = total
            break
    out.path = best or None
    return out
