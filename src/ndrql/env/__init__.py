"""Gymnasium environment ``ndrql/GridPath-v0`` (registered when this package is imported).

    import gymnasium as gym
    import ndrql.env  # noqa: F401
    env = gym.make("ndrql/GridPath-v0", render_mode="ansi")
"""

import gymnasium as gym

from ndrql.env.grid_path import DEFAULT_MAP, GridPathEnv

ENV_ID = "ndrql/GridPath-v0"

if ENV_ID not in gym.registry:
    gym.register(id=ENV_ID, entry_point="ndrql.env.grid_path:GridPathEnv")

__all__ = ["DEFAULT_MAP", "ENV_ID", "GridPathEnv"]
