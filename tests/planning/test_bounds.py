"""Q-learning's knobs are bounded where they are defined, and a run's memory follows the episodes it runs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ndrql.planning import reference, rng, rules
from ndrql.planning.config import MAX_EPISODES, PriorConfig, QLConfig
from ndrql.planning.methods import build_priors


def test_records_grow_past_their_first_block_and_match_the_reference():
    """A run of 2,500 episodes (window 2,400: far past the first 1,024 records) equals the numpy reference."""
    from ndrql.planning import kernel

    blocked = np.zeros((4, 4), dtype=bool)
    start, goal = (0, 0), (3, 3)
    pr = build_priors("QL", blocked, start, goal)
    cfg = QLConfig(window=2400, max_episodes=2500)
    ref = reference.train(blocked, start, goal, pr.r_c, pr.q0, 7, cfg)
    q = pr.q0.copy()
    n, steps, rets, succ, glen, conv, conv_steps, plen, path = kernel.train(
        rules.next_table(blocked), 0, 15, pr.r_c.ravel(), q, 7, cfg.alpha, cfg.gamma,
        rng.eps_threshold(cfg.epsilon), cfg.steps_cap(16), cfg.max_episodes, cfg.window,
        cfg.reward_collision, cfg.reward_goal, cfg.reward_revisit,
    )
    assert n == len(ref.steps) > 2048
    assert steps.size < 2 * n + 1024  # grown by doubling, not allocated for the cap
    assert steps[:n].tolist() == ref.steps
    assert glen[:n].tolist() == ref.greedy_length
    assert succ[:n].tolist() == ref.success
    assert (conv, conv_steps) == (ref.convergence_episode, ref.convergence_steps)


def test_a_huge_episode_cap_allocates_nothing_up_front():
    from ndrql.planning import kernel

    blocked = np.zeros((3, 3), dtype=bool)
    pr = build_priors("QL", blocked, (0, 0), (2, 2))
    out = kernel.train(rules.next_table(blocked), 0, 8, pr.r_c.ravel(), pr.q0.copy(), 0, 0.1, 0.95,
                       rng.eps_threshold(0.2), 36, MAX_EPISODES, 20, -10.0, 40.0, -5.0)
    assert out[1].size <= 1024 and out[5] >= 0


@pytest.mark.parametrize("field", ["reward_goal", "reward_collision", "reward_revisit", "alpha", "gamma", "epsilon"])
@pytest.mark.parametrize("value", [math.inf, -math.inf, math.nan, 1e300])
def test_ql_numbers_must_be_finite(field, value):
    with pytest.raises(ValueError, match=field):
        QLConfig(**{field: value})


@pytest.mark.parametrize("field", ["r0", "r_max", "mask_low", "g_row", "thd_step"])
@pytest.mark.parametrize("value", [math.inf, math.nan, "5", True])
def test_prior_numbers_must_be_finite_numbers(field, value):
    with pytest.raises(ValueError, match=field):
        PriorConfig(**{field: value})


@pytest.mark.parametrize("kw", [{"max_episodes": 0}, {"max_episodes": MAX_EPISODES + 1}, {"max_episodes": 2.5},
                                {"max_steps": 0}, {"window": True}, {"max_steps": 10**12}, {"max_episodes": 10**8}])
def test_counts_are_bounded_integers(kw):
    with pytest.raises(ValueError):
        QLConfig(**kw)
