"""The environments refuse out-of-range arguments with one NdrqlError line, as the CLI does."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ndrql.env  # noqa: F401  (registers the ids)
from ndrql.env import ENV_ID, RANDOM_ENV_ID
from ndrql.errors import NdrqlError


@pytest.mark.parametrize("kw, needle", [
    ({"size": 0}, "size"), ({"size": 10**6}, "size"), ({"size": 2.5}, "size"), ({"cell_px": 0}, "cell_px"),
    ({"cell_px": -3}, "cell_px"), ({"cell_px": 10**5}, "cell_px"), ({"start": (0.7, 0)}, "two integers"),
    ({"goal": (1, 2, 3)}, "two integers"), ({"start": (True, 0)}, "two integers"),
    ({"r_c": np.full((8, 8), np.nan)}, "finite"), ({"r_c": np.full((8, 8), np.inf)}, "finite"),
])
def test_grid_path_refuses(kw, needle):
    with pytest.raises(NdrqlError, match=needle):
        gym.make(ENV_ID, **kw)


@pytest.mark.parametrize("kw, needle", [({"size": 0}, "size"), ({"map_px": 10**6}, "map_px"), ({"map_px": 3}, "map_px"),
                                        ({"cell_px": 0}, "cell_px")])
def test_goal_path_refuses(kw, needle):
    with pytest.raises(NdrqlError, match=needle):
        gym.make(RANDOM_ENV_ID, **kw)


@pytest.mark.parametrize("seed", [-1, 2**63, 1.5])
def test_reset_refuses_a_seed_out_of_range(seed):
    env = gym.make(ENV_ID)
    with pytest.raises(NdrqlError, match="seed"):
        env.reset(seed=seed)
    assert env.reset(seed=2**63 - 1)[0] == 0


def test_reset_refuses_a_fractional_point():
    env = gym.make(ENV_ID)
    with pytest.raises(NdrqlError, match="two integers"):
        env.reset(options={"start": (0.7, 0)})
    assert env.reset(options={"start": (np.int64(0), 1)})[1]["start"] == (0, 1)


def test_a_grid_beyond_the_size_limit_and_huge_frames_are_refused():
    with pytest.raises(NdrqlError, match="at most 1024 cells"):
        gym.make(ENV_ID, grid=np.zeros((20000, 20000), bool))
    with pytest.raises(NdrqlError, match="frames of 65,536 px"):
        gym.make(ENV_ID, grid=np.zeros((1024, 1024), bool), render_mode="rgb_array", cell_px=64)
    env = gym.make(ENV_ID, grid=np.zeros((4, 4), bool), render_mode="rgb_array", cell_px=64)
    env.reset()
    assert env.render().shape[:2] == (256, 256)
