"""``ndrql/GridPathRandom-v0``: the Dict observation, map sources, determinism, reset options, priors."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import ndrql.env  # noqa: F401  (registers the ids)
from ndrql.env import RANDOM_ENV_ID, GoalGridPathEnv, grid_problem
from ndrql.env.observe import distance_channel
from ndrql.errors import NdrqlError
from ndrql.model.symmetry import DEFAULT_COUNT
from ndrql.maps.grid import bfs_distances
from ndrql.planning.priors import d_crf

DOC_SECTIONS = ("Description", "Action Space", "Observation Space", "Starting State", "Reward", "Episode End", "Arguments")


class FixedSource:
    """A source that always gives the same hand-made problem (a 6x7 grid, a wall open only in column 6)."""

    def __init__(self):
        blocked = np.zeros((6, 7), dtype=bool)
        blocked[2, :6] = True
        self.problem = grid_problem(blocked, (0, 0), (5, 6))

    def draw(self, rng):
        return self.problem


@pytest.mark.parametrize("kwargs", [
    {}, {"view": "ego", "view_size": 5}, {"prior": "oracle", "continuous_reward": "ndr", "render_mode": "rgb_array"},
    {"grid_rule": "safe", "families": ["rooms", "office"], "render_mode": "ansi"}, {"continuous_reward": "d-crf"},
])
def test_check_env_is_clean(kwargs):
    env = gym.make(RANDOM_ENV_ID, size=12, **kwargs)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check="render_mode" not in kwargs)


def test_docstring_sections():
    for section in DOC_SECTIONS:
        assert f"## {section}" in GoalGridPathEnv.__doc__


def rollout(env, seed, actions):
    obs, info = env.reset(seed=seed)
    out = [obs["image"].copy(), info["start"], info["goal"], info["map"]]
    for a in actions:
        obs, r, term, trunc, _ = env.step(a)
        out += [obs["image"].copy(), r]
        if term or trunc:
            obs, info = env.reset()
            out += [obs["image"].copy(), info["map"]]
    return out


def same(a, b):
    return len(a) == len(b) and all(np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y for x, y in zip(a, b))


def test_same_seed_same_maps_and_rollout_seed_plus_one_differs():
    actions = list(np.random.default_rng(0).integers(0, 4, size=300))
    a = rollout(GoalGridPathEnv(size=12), 11, actions)
    np.random.seed(1)  # the global generator must not matter
    b = rollout(GoalGridPathEnv(size=12), 11, actions)
    c = rollout(GoalGridPathEnv(size=12), 12, actions)
    assert same(a, b)
    assert not same(a, c)
    env = GoalGridPathEnv(size=12)
    maps = {env.reset(seed=3 if i == 0 else None)[1]["map"] + str(env.problem.blocked.tobytes()) for i in range(8)}
    assert len(maps) > 1  # a new map each episode


def test_full_view_known_answer():
    env = GoalGridPathEnv(source=FixedSource(), size=8)
    obs, info = env.reset(seed=0)
    img = obs["image"]
    assert img.shape == (4, 8, 8) and img.dtype == np.float32
    blocked = FixedSource().problem.blocked
    assert np.array_equal(img[0, :6, :7], blocked) and img[0, 6:, :].all() and img[0, :, 7].all()  # padding = obstacle
    assert img[2, 0, 0] == 1 and img[2].sum() == 1  # agent
    assert img[3, 5, 6] == 1 and img[3].sum() == 1  # goal
    assert img[1, 0, 0] == 1 and img[1].sum() == 1  # the start is visited
    np.testing.assert_allclose(obs["goal"], [5 / 8, 6 / 8])
    assert info["astar_length"] == 11
    obs, r, *_ = env.step(3)  # right
    assert r == 0.0 and obs["image"][2, 0, 1] == 1 and obs["image"][1, 0, :2].all()
    obs, r, *_ = env.step(2)  # back left: a revisit, and the observation shows it was visited
    assert r == -5.0 and obs["image"][1, 0, 0] == 1
    env.step(1)  # down to (1, 0)
    env.step(3)  # right to (1, 1)
    obs, r, _, _, info = env.step(1)  # down into the wall
    assert r == -10.0 and info["outcome"] == "collision" and info["cell"] == (1, 1)


def test_ego_view_pads_with_obstacles():
    env = GoalGridPathEnv(source=FixedSource(), size=8, view="ego", view_size=5)
    obs, _ = env.reset(seed=0)
    img = obs["image"]
    assert img.shape == (4, 5, 5)
    assert img[0, :2, :].all() and img[0, :, :2].all()  # off the grid above and left of (0, 0)
    assert img[2, 2, 2] == 1  # the agent in the centre
    assert np.array_equal(img[0, 2:, 2:], FixedSource().problem.blocked[:3, :3])
    assert img[3].sum() == 0  # the goal is out of view; the goal vector still points at it
    np.testing.assert_allclose(obs["goal"], [5 / 8, 6 / 8])


def test_continuous_reward_d_crf_is_eq2():
    env = GoalGridPathEnv(source=FixedSource(), size=8, continuous_reward="d-crf")
    env.reset(seed=0)
    _, r, *_ = env.step(3)
    assert r == pytest.approx(d_crf((6, 7), (5, 6))[0, 1])


def test_oracle_prior_channels_follow_the_shortest_path():
    env = GoalGridPathEnv(source=FixedSource(), size=8, prior="oracle")
    obs, _ = env.reset(seed=0)
    region, guideline = obs["image"][4, :6, :7], obs["image"][5, :6, :7]
    assert obs["image"].shape == (6, 8, 8)
    assert 0 <= guideline.min() and guideline.max() <= 1 and region.max() == 1
    # the only way round the wall is through column 6: the guideline runs there, not down column 0
    assert guideline[2, 6] > 0 and guideline[3:, 0].sum() == 0


def test_oracle_distance_channel_is_the_exact_goal_distance():
    env = GoalGridPathEnv(source=FixedSource(), size=8, prior="oracle", prior_distance=True)
    obs, _ = env.reset(seed=0)
    assert obs["image"].shape == (7, 8, 8)
    blocked = FixedSource().problem.blocked
    d = bfs_distances(blocked, FixedSource().problem.goal)
    channel = obs["image"][6, :6, :7]
    free = d >= 0
    np.testing.assert_allclose(channel[free], d[free] / (d[free] + 8.0), rtol=1e-6)
    assert channel[FixedSource().problem.goal] == 0 and np.all(channel[~free] == 1)
    assert np.array_equal(obs["image"][:6], GoalGridPathEnv(source=FixedSource(), size=8, prior="oracle")
                          .reset(seed=0)[0]["image"])  # the other channels do not move


def test_distance_channel_keeps_the_order_of_long_detours():
    d = np.array([0.0, 1.0, 8.0, 100.0, 1000.0, -1.0])
    c = distance_channel(d, 8)
    assert c[0] == 0 and c[2] == pytest.approx(0.5) and c[-1] == 1 and np.all(np.diff(c[:-1]) > 0) and c[4] < 1


def test_reset_options_play_one_episode_on_a_given_map():
    env = GoalGridPathEnv(size=10)
    m = np.zeros((40, 40), dtype=bool)
    m[18:22, :32] = True
    obs, info = env.reset(seed=0, options={"map": m, "start": (2, 2), "goal": (37, 2)})
    assert info["map"] == "array" and info["astar_length"] == 25 and info["start"] == (0, 0)
    assert np.array_equal(obs["image"][0, 4:6, :8], np.ones((2, 8)))
    _, info = env.reset()
    assert info["map"].startswith("family:")
    with pytest.raises(NdrqlError, match="missing: goal"):
        env.reset(options={"map": m, "start": (2, 2)})


def test_ndr_prior_from_the_shipped_model(model_weights):
    # before the tiny dataset's tests: they point $NDRQL_CACHE (and with it the ONNX export cache) elsewhere
    env = GoalGridPathEnv(size=12, prior="ndr", continuous_reward="ndr", weights=model_weights)
    obs, _ = env.reset(seed=0)
    prior = obs["image"][4:]
    assert prior.shape == (2, 12, 12) and 0 <= prior.min() and prior.max() <= 1 and prior[0].max() > 0.5


@pytest.mark.parametrize("symmetries", [4, 1])
def test_ndr_prior_of_a_grid_mode_model_is_predicted_on_the_envs_own_grid(model_weights, symmetries):
    """The default (general, grid-mode) model sees the env's planning grid at 4 px per cell, as in ndrql plan
    (one forward pass, plan's default, or averaged over orientations when told): the prior channels are the 4x4 means of its
    prediction for exactly that grid, start and goal, and the distance channel its distance head's."""
    from ndrql.dataset.render import cell_means
    from ndrql.model.predict import load_predictor

    predictor = load_predictor(model_weights, symmetries=symmetries)
    if predictor.input_mode != "grid":
        pytest.skip(f"{model_weights} holds a map-mode model")
    kwargs = {} if symmetries == DEFAULT_COUNT else {"symmetries": symmetries}
    env = GoalGridPathEnv(size=20, prior="ndr", weights=model_weights, prior_distance=True, **kwargs)
    obs, info = env.reset(seed=3)
    blocked = obs["image"][0, :20, :20].astype(bool)
    r, g, d = predictor.predict_grid_all(blocked, tuple(info["start"]), tuple(info["goal"]))
    if d is None:
        pytest.skip(f"{model_weights} has no distance head")
    h, w = blocked.shape
    assert obs["image"].shape == (7, 20, 20)
    assert np.allclose(obs["image"][4, :h, :w], cell_means(r, blocked.shape), atol=1e-6)
    assert np.allclose(obs["image"][5, :h, :w], cell_means(g, blocked.shape), atol=1e-6)
    assert np.allclose(obs["image"][6, :h, :w], distance_channel(cell_means(d, blocked.shape), 20), atol=1e-6)
    if symmetries == 4:
        plain = GoalGridPathEnv(size=20, prior="ndr", weights=model_weights).reset(seed=3)[0]["image"][4]
        assert not np.allclose(plain[:h, :w], obs["image"][4, :h, :w], atol=1e-4)  # the default is one forward pass


def test_distance_prior_of_a_model_without_distance_head_is_one_clear_error():
    env = GoalGridPathEnv(size=12, prior="ndr", prior_distance=True, weights="paper")  # the paper's model has none
    with pytest.raises(NdrqlError, match="distance head"):
        env.reset(seed=0)


def test_dataset_source(tiny_dataset):
    from ndrql.dataset.cache import load_split
    from ndrql.maps.grid import point_to_cell

    env = GoalGridPathEnv(source="dataset", data=tiny_dataset, split="train", size=25)
    data = load_split(tiny_dataset, "train", progress=False)
    seen = set()
    for i in range(6):
        _, info = env.reset(seed=i)
        kind, split, index = info["map"].split(":")
        assert (kind, split) == ("dataset", "train")
        sr, sc, gr, gc = data.points[int(index)]
        assert info["start"] == point_to_cell((sr, sc), (201, 201), (25, 25))
        assert info["goal"] == point_to_cell((gr, gc), (201, 201), (25, 25))
        seen.add(index)
    assert len(seen) > 1


def test_bad_arguments():
    for kwargs, match in [({"view": "top"}, "unknown view"), ({"prior": "gps"}, "unknown prior"),
                          ({"continuous_reward": "ndr"}, "needs prior"), ({"source": "dataset"}, "needs data"),
                          ({"source": "web"}, "unknown source"), ({"view": "ego", "view_size": 4}, "odd"),
                          ({"families": ["mazes"]}, "valid: blocks"), ({"prior_distance": True}, "needs prior"),
                          ({"prior": "ndr", "symmetries": 3}, "symmetries must be one of")]:
        with pytest.raises(NdrqlError, match=match):
            GoalGridPathEnv(**kwargs)
    with pytest.raises(NdrqlError, match="reset"):
        GoalGridPathEnv().step(0)
