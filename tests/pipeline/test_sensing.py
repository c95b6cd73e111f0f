"""Revealed as it moves: priors rebuilt on the growing belief, the Q-table kept (ndrql.pipeline.sensing)."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.pipeline.sensing import SenseConfig, chunk_seed, run_sensed, sense
from ndrql.planning.config import QLConfig
from ndrql.planning.methods import build_priors
from ndrql.planning.runner import run_plan

S, G = (2, 2), (2, 17)


def _truth() -> np.ndarray:
    """20x20 cells, a wall at column 10 from the top to row 15 (the way round is at the bottom)."""
    t = np.zeros((20, 20), dtype=bool)
    t[0:16, 10] = True
    return t


def _priors_on(b: np.ndarray):
    return build_priors("IQL-BFS", b, S, G)


def test_sense_sees_within_the_radius_and_not_through_walls():
    seen = sense(_truth(), np.array([[5, 7]]), 4.0)
    assert seen[5, 9] and seen[5, 10]  # up to the wall and the wall itself
    assert not seen[5, 11]  # behind it
    assert seen[5, 3] and not seen[5, 2]  # the radius


def test_a_known_map_is_a_plain_run_with_the_chunk_seed():
    t = _truth()
    cfg = QLConfig()
    r = run_sensed(t, t, np.ones_like(t), S, G, "IQL-BFS", 7, cfg, _priors_on, SenseConfig(radius=3, every=10**6))
    plain = run_plan(t, S, G, "IQL-BFS", chunk_seed(7, 0), cfg, priors=_priors_on(t))
    assert r.converged and r.recomputes == 0
    assert (r.steps, r.episodes, r.path_length) == (plain.convergence_steps, plain.episodes, plain.path_length)


def test_the_hidden_wall_is_revealed_and_the_priors_rebuilt():
    t = _truth()
    belief = t.copy()
    belief[0:16, 10] = False  # the planner does not know the wall
    known = np.ones_like(t)
    known[0:16, 8:13] = False
    cfg = QLConfig()
    a = run_sensed(t, belief, known, S, G, "IQL-BFS", 1, cfg, _priors_on, SenseConfig(radius=3, every=5))
    b = run_sensed(t, belief, known, S, G, "IQL-BFS", 1, cfg, _priors_on, SenseConfig(radius=3, every=5))
    assert a.converged and a.recomputes >= 1 and a.path_length >= a.astar_length == 43
    assert a.known_share[0] > known.mean() and a.known_share == sorted(a.known_share)
    assert (a.steps, a.episodes, a.recomputes) == (b.steps, b.episodes, b.recomputes)  # same seed, same run


def test_sense_config_refuses_nonsense():
    with pytest.raises(ValueError):
        SenseConfig(radius=0)
    with pytest.raises(ValueError):
        SenseConfig(radius=2, every=0)
