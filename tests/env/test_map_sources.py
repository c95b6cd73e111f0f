"""``ndrql/GridPath-v0`` built from map files, reset options, the registered time limit; the sources."""

from __future__ import annotations

import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from PIL import Image

import ndrql.env  # noqa: F401  (registers the ids)
from ndrql.env import ENV_ID, RANDOM_ENV_ID, GeneratorSource, GridPathEnv, map_problem
from ndrql.errors import NdrqlError, NoPathError, PointError
from ndrql.planning import rules


def wall_map() -> np.ndarray:
    """40x40 px, a wall over rows 18-21 from column 0 to 31: on the 10x10 area grid, cell rows 4 and 5
    are blocked in columns 0..7 (each cell exactly half wall), columns 8 and 9 stay open."""
    m = np.zeros((40, 40), dtype=bool)
    m[18:22, :32] = True
    return m


@pytest.fixture()
def wall_png(tmp_path):
    path = tmp_path / "wall.png"
    Image.fromarray(np.where(wall_map(), 0, 255).astype(np.uint8)).save(path)
    return path


def test_registered_time_limits():
    assert gym.spec(ENV_ID).max_episode_steps == 4 * 50 * 50
    assert gym.spec(RANDOM_ENV_ID).max_episode_steps == 4 * 16 * 16
    env = gym.make(ENV_ID)
    assert env.spec.max_episode_steps == 10_000 and env.unwrapped.max_steps == 4 * 64


def test_env_from_a_map_file_known_answer(wall_png):
    env = gym.make(ENV_ID, map=str(wall_png), start=(2, 2), goal=(37, 2), size=10, grid_rule="area")
    inner = env.unwrapped
    expected = np.zeros((10, 10), dtype=bool)
    expected[4:6, :8] = True
    assert np.array_equal(inner.blocked, expected)
    obs, info = env.reset(seed=0)
    assert obs == 0 and info["start"] == (0, 0) and info["goal"] == (9, 0)
    assert info["astar_length"] == 25  # 8 right, 9 down, 8 left around the wall
    assert env.observation_space.n == 100
    # walk the shortest path: 8 right, 9 down, 8 left; the last move reaches the goal (+40)
    total = 0.0
    for a in [3] * 8 + [1] * 9 + [2] * 8:
        obs, r, term, trunc, _ = env.step(a)
        total += r
    assert term and not trunc and obs == rules.cell_index((9, 0), 10)
    assert total == 40.0  # r_c = 0 on every other move
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(inner)


def test_env_from_array_and_safe_rule():
    m = wall_map()
    m[0:3, 20] = True  # a 1-px post: the safe rule blocks its cell, the area rule does not
    area = GridPathEnv(map=m, start=(2, 2), goal=(37, 2), size=10, grid_rule="area")
    safe = GridPathEnv(map=m, start=(2, 2), goal=(37, 2), size=10, grid_rule="safe")
    assert not area.blocked[0, 5] and safe.blocked[0, 5]
    assert safe.problem.astar_length == 25


def test_reset_options_start_goal_and_map(wall_png, tmp_path):
    env = GridPathEnv(map=str(wall_png), start=(2, 2), goal=(37, 2), size=10, grid_rule="area")
    obs, info = env.reset(seed=0, options={"start": (37, 38)})  # map pixels
    assert info["start"] == (9, 9) and info["goal"] == (9, 0) and info["astar_length"] == 9
    obs, info = env.reset()  # options apply until changed
    assert info["start"] == (9, 9)
    other = np.zeros((40, 40), dtype=bool)
    obs, info = env.reset(options={"map": other, "start": (2, 2), "goal": (37, 37)})
    assert not env.blocked.any() and info["astar_length"] == 18
    safe = GridPathEnv(map=str(wall_png), start=(2, 2), goal=(37, 2), size=10, grid_rule="safe")
    with pytest.raises(NdrqlError, match="observation space is for 10x10"):  # the safe grid keeps the aspect
        safe.reset(options={"map": np.zeros((40, 20), dtype=bool), "goal": (37, 17)})
    with pytest.raises(PointError, match="on an obstacle"):
        env.reset(options={"map": wall_map(), "start": (20, 5), "goal": (37, 2)})


def test_reset_options_on_a_grid_env():
    env = GridPathEnv()  # the 8x8 default map, cells
    _, info = env.reset(seed=0, options={"goal": (0, 7)})
    assert info["goal"] == (0, 7) and info["astar_length"] == 7
    grid = np.zeros((8, 8), dtype=bool)
    _, info = env.reset(options={"grid": grid, "start": (7, 7)})
    assert info["start"] == (7, 7) and info["goal"] == (0, 7) and info["astar_length"] == 7
    with pytest.raises(NdrqlError, match="not both"):
        env.reset(options={"grid": grid, "map": grid})


def test_map_problem_errors(wall_png):
    with pytest.raises(PointError, match="needs start and goal"):
        GridPathEnv(map=str(wall_png))
    with pytest.raises(PointError, match="off the map"):
        map_problem(str(wall_png), (2, 2), (40, 2), size=10)
    with pytest.raises(PointError, match="same planning cell"):
        map_problem(str(wall_png), (1, 1), (2, 2), size=10)
    closed = wall_map()
    closed[18:22, :] = True
    with pytest.raises(NoPathError):
        map_problem(closed, (2, 2), (37, 2), size=10)
    with pytest.raises(NdrqlError, match="grid_rule"):
        GridPathEnv(map=closed, start=(2, 2), goal=(37, 2), grid_rule="coarse")
    with pytest.raises(NdrqlError, match="give map"):
        GridPathEnv(size=10)  # a size without a map would be ignored: an error instead


def test_generator_source_is_deterministic_and_valid():
    src = GeneratorSource(families=("maze", "blocks"), map_px=48, size=12)
    a = [src.draw(np.random.default_rng(5)) for _ in range(2)]
    b = src.draw(np.random.default_rng(6))
    assert np.array_equal(a[0].blocked, a[1].blocked) and a[0].start == a[1].start and a[0].goal == a[1].goal
    assert not (np.array_equal(a[0].blocked, b.blocked) and a[0].start == b.start)
    rng = np.random.default_rng(0)
    for _ in range(20):
        p = src.draw(rng)
        assert p.blocked.shape == (12, 12) and p.name in ("family:maze", "family:blocks")
        assert not p.blocked[p.start] and not p.blocked[p.goal] and p.start != p.goal
        assert p.astar_length >= abs(p.start[0] - p.goal[0]) + abs(p.start[1] - p.goal[1])
    with pytest.raises(NdrqlError, match="valid: blocks"):
        GeneratorSource(families=("mazes",))


def test_importing_the_envs_loads_neither_torch_nor_numba():
    code = "import sys, ndrql.env; print('torch' in sys.modules, 'numba' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]
