"""The Gymnasium environment ``ndrql/GridPath-v0``: API checks and agreement with the kernel's rules."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import ndrql.env  # noqa: F401  (registers the id)
from ndrql.env import ENV_ID, GridPathEnv
from ndrql.planning import rules
from ndrql.planning.priors import d_crf


def small_problem():
    blocked = np.zeros((6, 7), dtype=bool)
    blocked[2, 1:6] = True
    blocked[4, 3] = True
    return blocked, (0, 0), (5, 6)


@pytest.mark.parametrize("kwargs", [{}, {"render_mode": "ansi"}, {"render_mode": "rgb_array", "random_start": True}])
def test_check_env_is_clean(kwargs):
    env = gym.make(ENV_ID, **kwargs)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=False)


def test_docstring_sections():
    doc = GridPathEnv.__doc__
    for section in ("Description", "Action Space", "Observation Space", "Starting State", "Reward", "Episode End", "Arguments"):
        assert f"## {section}" in doc


def test_env_and_compiled_kernel_agree_on_action_sequences():
    """Step the env and the kernel's compiled transition through the same actions."""
    from ndrql.planning import kernel

    blocked, start, goal = small_problem()
    r_c = d_crf(blocked.shape, goal)
    env = GridPathEnv(blocked, start, goal, r_c=r_c)
    nxt = rules.next_table(blocked)
    w = blocked.shape[1]
    g = rules.cell_index(goal, w)
    gen = np.random.default_rng(42)
    visited = np.zeros(blocked.size, dtype=np.int64)
    outcomes = set()
    for episode in range(30):
        obs, _ = env.reset(seed=episode)
        s = rules.cell_index(start, w)
        assert obs == s
        mark = episode + 1
        visited[s] = mark
        for a in gen.integers(0, 4, size=200):
            obs, reward, terminated, truncated, info = env.step(int(a))
            s2, r, outcome = kernel._step(nxt, g, r_c.ravel(), visited, mark, s, int(a), -10.0, 40.0, -5.0)
            assert (obs, reward, terminated) == (int(s2), float(r), outcome == rules.GOAL)
            assert info["outcome"] == rules.OUTCOME_NAMES[outcome]
            outcomes.add(info["outcome"])
            s = int(s2)
            if terminated or truncated:
                break
    assert outcomes == {"move", "collision", "revisit", "goal"}


def test_truncation_after_max_steps():
    from ndrql.planning.config import QLConfig

    blocked, start, goal = small_problem()
    env = GridPathEnv(blocked, start, goal, config=QLConfig(max_steps=5))
    env.reset(seed=0)
    for i in range(5):
        _, r, term, trunc, _ = env.step(0)  # bump into the top edge
        assert r == -10.0 and not term
    assert trunc
    assert GridPathEnv(blocked, start, goal).max_steps == 4 * blocked.size


def test_random_start_uses_only_the_env_generator():
    blocked, start, goal = small_problem()
    a = GridPathEnv(blocked, start, goal, random_start=True)
    b = GridPathEnv(blocked, start, goal, random_start=True)
    np.random.seed(0)
    sa = [a.reset(seed=7)[0]] + [a.reset()[0] for _ in range(10)]
    np.random.seed(1)
    sb = [b.reset(seed=7)[0]] + [b.reset()[0] for _ in range(10)]
    assert sa == sb
    assert len(set(sa)) > 1
    assert all(not blocked[rules.index_cell(s, 7)] and s != rules.cell_index(goal, 7) for s in sa)


def test_renders():
    blocked, start, goal = small_problem()
    env = GridPathEnv(blocked, start, goal, render_mode="ansi")
    env.reset(seed=0)
    env.step(3)
    text = env.render()
    lines = text.splitlines()
    assert lines[0] == "SA....." and lines[2] == ".#####." and lines[5][-1] == "G"
    env = GridPathEnv(blocked, start, goal, render_mode="rgb_array", cell_px=4)
    env.reset(seed=0)
    img = env.render()
    assert img.shape == (24, 28, 3) and img.dtype == np.uint8
    assert tuple(img[0, 0]) == (40, 170, 60)  # the agent on the start cell


def test_bad_arguments():
    from ndrql.errors import NdrqlError, NoPathError, PointError

    blocked, start, goal = small_problem()
    with pytest.raises(PointError, match="free cell"):
        GridPathEnv(blocked, (2, 2), goal)
    with pytest.raises(NdrqlError, match="render_mode"):
        GridPathEnv(blocked, start, goal, render_mode="human")
    walled = blocked.copy()
    walled[2, :] = True
    with pytest.raises(NoPathError, match="not 4-connected"):
        GridPathEnv(walled, start, goal)
    with pytest.raises(NdrqlError, match="not both"):
        GridPathEnv(blocked, start, goal, map=blocked)
    env = GridPathEnv(blocked, start, goal)
    env.reset(seed=0)
    with pytest.raises(NdrqlError, match="invalid action"):
        env.step(7)
    with pytest.raises(NdrqlError, match="unknown reset option 'mpa'"):
        env.reset(options={"mpa": blocked})
