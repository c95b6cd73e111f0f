"""The rules of Eq. 1 are defined once and every implementation agrees with them."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.planning import reference, rng, rules
from ndrql.planning.config import QLConfig
from ndrql.planning.methods import build_priors

# 0 1 2 3
# . . # .   row 0
# . . . .   row 1
# # . . .   row 2
TINY = np.array([[0, 0, 1, 0], [0, 0, 0, 0], [1, 0, 0, 0]], dtype=bool)


def test_next_table_blocked_and_off_map_moves_stay():
    nxt = rules.next_table(TINY)
    w = TINY.shape[1]
    s = rules.cell_index((0, 1), w)
    up, down, left, right = nxt[s]
    assert up == s  # off the map
    assert down == rules.cell_index((1, 1), w)
    assert left == rules.cell_index((0, 0), w)
    assert right == s  # (0, 2) is blocked
    s = rules.cell_index((1, 0), w)
    assert nxt[s, 1] == s  # (2, 0) is blocked


def test_action_order_matches_the_maps_package():
    from ndrql.maps.grid import MOVES4

    assert rules.ACTIONS == MOVES4


def test_step_rewards_of_eq1():
    nxt = rules.next_table(TINY)
    w = TINY.shape[1]
    goal = rules.cell_index((2, 3), w)
    r_c = np.arange(TINY.size, dtype=float) / 10
    visited = np.zeros(TINY.size, dtype=np.int64)
    s = rules.cell_index((0, 0), w)
    visited[s] = 1
    args = (-10.0, 40.0, -5.0)
    # collision: stay, -10
    assert rules.step(nxt, goal, r_c, visited, 1, s, 0, *args) == (s, -10.0, rules.COLLISION)
    # plain move: r_c of the cell entered
    s2 = rules.cell_index((0, 1), w)
    assert rules.step(nxt, goal, r_c, visited, 1, s, 3, *args) == (s2, r_c[s2], rules.MOVE)
    # back to a visited cell: -5
    assert rules.step(nxt, goal, r_c, visited, 1, s2, 2, *args) == (s, -5.0, rules.REVISIT)
    # a new episode mark forgets the visits
    assert rules.step(nxt, goal, r_c, visited, 2, s2, 2, *args)[2] == rules.MOVE
    # the goal: +40, terminal
    s3 = rules.cell_index((1, 3), w)
    assert rules.step(nxt, goal, r_c, visited, 1, s3, 1, *args) == (goal, 40.0, rules.GOAL)


def test_compiled_step_equals_python_step():
    from ndrql.planning import kernel

    nxt = rules.next_table(TINY)
    r_c = np.linspace(0, 1, TINY.size)
    goal = rules.cell_index((2, 3), 4)
    gen = np.random.default_rng(0)
    va = np.zeros(TINY.size, dtype=np.int64)
    vb = np.zeros(TINY.size, dtype=np.int64)
    s = 0
    va[s] = vb[s] = 1
    for a in gen.integers(0, 4, size=300):
        pa = rules.step(nxt, goal, r_c, va, 1, s, int(a), -10.0, 40.0, -5.0)
        pb = kernel._step(nxt, goal, r_c, vb, 1, s, int(a), -10.0, 40.0, -5.0)
        assert (int(pa[0]), float(pa[1]), int(pa[2])) == (int(pb[0]), float(pb[1]), int(pb[2]))
        assert np.array_equal(va, vb)
        s = 0 if pa[2] == rules.GOAL else int(pa[0])


def test_kernel_rng_is_the_python_generator_compiled():
    from ndrql.planning import kernel

    for seed in (0, 1, 2**63 - 1, 123456789):
        st = rng.seed_state(seed)
        assert [int(x) for x in kernel._draws(seed, 50)] == [rng.next_u64(st) for _ in range(50)]


def test_rng_known_answers():
    """splitmix64 and xoshiro256** against their published definitions, written out with Python ints."""
    mask = (1 << 64) - 1
    x, words = 7, []
    for _ in range(4):
        x = (x + 0x9E3779B97F4A7C15) & mask
        z = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & mask
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & mask
        words.append(z ^ (z >> 31))
    st = rng.seed_state(7)
    assert [int(w) for w in st] == words
    s0, s1, s2, s3 = words
    for _ in range(20):
        x = (s1 * 5) & mask
        expected = ((((x << 7) | (x >> 57)) & mask) * 9) & mask
        t = (s1 << 17) & mask
        s2 ^= s0
        s3 ^= s1
        s1 ^= s2
        s0 ^= s3
        s2 ^= t
        s3 = ((s3 << 45) | (s3 >> 19)) & mask
        assert rng.next_u64(st) == expected


def test_eps_threshold_and_pick():
    assert rng.eps_threshold(0.0) == 0
    assert rng.eps_threshold(1.0) == 2**32
    assert rng.eps_threshold(0.2) == round(0.2 * 2**32)
    assert {rng.pick(u, 3) for u in (0, 2**32 - 1, 2**31)} <= {0, 1, 2}
    with pytest.raises(ValueError):
        rng.eps_threshold(1.5)


@pytest.mark.parametrize("method", ["QL", "IQL"])
@pytest.mark.parametrize("seed", [3, 4])
def test_kernel_and_numpy_reference_make_the_same_run(method, seed):
    """Same rules, same random stream: identical Q-tables, episodes and greedy path, bit for bit."""
    from ndrql.planning import kernel

    blocked = np.zeros((9, 9), dtype=bool)
    blocked[1:7, 4] = True
    blocked[5, 1:4] = True
    start, goal = (0, 0), (8, 8)
    pr = build_priors(method, blocked, start, goal)
    cfg = QLConfig()
    ref = reference.train(blocked, start, goal, pr.r_c, pr.q0, seed, cfg)
    q = pr.q0.copy()
    n, steps, rets, succ, glen, conv, conv_steps, plen, path = kernel.train(
        rules.next_table(blocked), 0, 80, pr.r_c.ravel(), q, seed, cfg.alpha, cfg.gamma,
        rng.eps_threshold(cfg.epsilon), cfg.steps_cap(81), cfg.max_episodes, cfg.window,
        cfg.reward_collision, cfg.reward_goal, cfg.reward_revisit,
    )
    assert ref.convergence_episode >= 0
    assert n == len(ref.steps)
    assert steps[:n].tolist() == ref.steps
    assert rets[:n].tolist() == ref.returns
    assert succ[:n].tolist() == ref.success
    assert glen[:n].tolist() == ref.greedy_length
    assert (conv, conv_steps) == (ref.convergence_episode, ref.convergence_steps)
    assert path[: plen + 1].tolist() == ref.path
    assert np.array_equal(q, ref.q)
