"""Hand-made planning problems and a small study configuration for the tuning tests.

Shared by ``tuning/test_tune.py`` and the child process of its kill-and-resume test (which imports this
module with ``tests/`` on its path).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ndrql.maps.astar import astar4
from ndrql.maps.problem import MapProblem
from ndrql.pipeline.samples import Problem


def make_problem(key: str, n: int = 14, gap_col: int = 11) -> Problem:
    """An n x n grid with a wall across row n // 2 and one gap; region/guideline on the A* path."""
    blocked = np.zeros((n, n), dtype=bool)
    blocked[n // 2, :] = True
    blocked[n // 2, gap_col] = False
    start, goal = (1, 1), (n - 2, 1)
    res = astar4(blocked, start, goal)
    guide = np.zeros((n, n))
    for r, c in res.path:
        guide[r, c] = 1.0
    region = np.clip(guide + np.roll(guide, 1, 0) + np.roll(guide, -1, 1), 0, 1)
    return Problem(key, 0, "", MapProblem(blocked, start, goal), blocked, start, goal, int(res.moves), region, guide)


#: Three problems of different sizes and gaps.
PROBLEMS = [make_problem("a", 14, 11), make_problem("b", 12, 9), make_problem("c", 14, 4)]


def tune_config(method: str = "IQL", trials: int = 6, seed: int = 0, **kw: Any) -> Any:
    """A ``TuneConfig`` small enough for a test: :data:`PROBLEMS`, 2 seeds, chunks of one run."""
    from ndrql.tuning.study import TuneConfig  # needs optuna: the test module skips without it first

    return TuneConfig(method, trials=trials, samples=len(PROBLEMS), seeds=2, seed=seed, chunk=1, max_episodes=3000,
                      startup_trials=3, prune_warmup=1, **kw)
