"""Gymnasium environments (registered when this package is imported).

- ``ndrql/GridPath-v0`` (:class:`GridPathEnv`): the tabular Q-learning problem of the paper (Eq. 1) on
  one map: the observation is the cell, as in the Q-learning kernel;
- ``ndrql/GridPathRandom-v0`` (:class:`GoalGridPathEnv`): goal-conditioned, a new map every episode
  from a generator or the dataset, a ``Dict`` observation (image of obstacles, visited cells, agent,
  goal, optionally the NDR region and guideline), for deep RL.

::

    import gymnasium as gym
    import ndrql.env  # noqa: F401  (registers the ids)
    env = gym.make("ndrql/GridPath-v0", map="office.yaml", start=(120, 80), goal=(30, 200))
    env = gym.make("ndrql/GridPathRandom-v0", size=16, view="ego")

Importing this package loads neither torch nor numba; the NDR prior loads the model on first use.
"""

import gymnasium as gym

from ndrql.env.goal_path import GoalGridPathEnv
from ndrql.env.grid_path import DEFAULT_MAP, GridPathEnv
from ndrql.env.sources import DatasetSource, EnvProblem, GeneratorSource, grid_problem, map_problem
from ndrql.maps.grid import PLANNING_SIZE

ENV_ID = "ndrql/GridPath-v0"
RANDOM_ENV_ID = "ndrql/GridPathRandom-v0"

#: ``TimeLimit`` of ``ndrql/GridPath-v0``: 4 x cells of the paper's 50x50 planning grid (the env's own
#: cap, ``4 * h * w``, ends smaller grids' episodes first).
GRID_PATH_MAX_STEPS = 4 * PLANNING_SIZE * PLANNING_SIZE
#: ``TimeLimit`` of ``ndrql/GridPathRandom-v0``: 4 x cells of its default 16x16 grid.
RANDOM_MAX_STEPS = 4 * 16 * 16

if ENV_ID not in gym.registry:
    gym.register(id=ENV_ID, entry_point="ndrql.env.grid_path:GridPathEnv", max_episode_steps=GRID_PATH_MAX_STEPS)
if RANDOM_ENV_ID not in gym.registry:
    gym.register(id=RANDOM_ENV_ID, entry_point="ndrql.env.goal_path:GoalGridPathEnv",
                 max_episode_steps=RANDOM_MAX_STEPS)

__all__ = [
    "DEFAULT_MAP", "ENV_ID", "RANDOM_ENV_ID", "DatasetSource", "EnvProblem", "GeneratorSource", "GoalGridPathEnv",
    "GridPathEnv", "grid_problem", "map_problem",
]
