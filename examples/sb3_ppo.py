#!/usr/bin/env python3
"""PPO from stable-baselines3 on ndrql's two Gymnasium environments, scored against A*.

    pip install 'ndrql[rl]'                       # stable-baselines3 (and torch)
    python examples/sb3_ppo.py                    # both envs, a few minutes of one CPU core
    python examples/sb3_ppo.py --env random --timesteps 200000 --n-envs 8
    python examples/sb3_ppo.py --quick            # a smoke run of a few seconds (what CI runs)

1. ``ndrql/GridPath-v0`` (tabular: the observation is the cell) on the bundled map at
   ``--map-size`` cells, with the D-CRF continuous reward of Eq. 2: one map and goal, a random
   start each episode (scored from random starts too).
2. ``ndrql/GridPathRandom-v0`` (goal-conditioned ``Dict`` observation, egocentric view): a new
   generated map every episode; scored on maps it never trained on (other seeds).

Both train on ``--n-envs`` copies in a vector env (``make_vec_env``: sub-env ``i`` is seeded
``seed + i``, so the run is reproducible). Each prints the success rate of the greedy policy and its
path length against the A* optimum on the same grid (A* succeeds on every problem by construction).
"""

from __future__ import annotations

import argparse
import time
import warnings

import gymnasium as gym
import numpy as np

import ndrql.env  # noqa: F401  (registers the ids)
from ndrql.env import ENV_ID, RANDOM_ENV_ID
from ndrql.maps.bundled import bundled_sample
from ndrql.planning.priors import d_crf


def _key(obs) -> bytes:
    if isinstance(obs, dict):
        return b"".join(np.asarray(obs[k]).tobytes() for k in sorted(obs))
    return np.asarray(obs).tobytes()


def evaluate(model, env: gym.Env, episodes: int, seed: int) -> dict[str, float]:
    """Greedy rollouts: success rate, and moves / A* moves over the successful episodes.

    A rollout that sees the same observation twice counts as a failure: the greedy policy would
    repeat itself until the time limit (exactly so when the observation is the whole state: the
    tabular env, and the full view).
    """
    successes, ratios = 0, []
    for k in range(episodes):
        obs, info = env.reset(seed=seed + k)
        astar = info["astar_length"]
        done, moves, reached, seen = False, 0, False, set()
        while not done:
            key = _key(obs)
            if key in seen:
                break
            seen.add(key)
            action, _ = model.predict(obs, deterministic=True)
            obs, _, terminated, truncated, _ = env.step(int(action))
            moves += 1
            reached, done = terminated, terminated or truncated
        if reached:
            successes += 1
            ratios.append(moves / astar)
    return {"success": successes / episodes, "ratio": float(np.mean(ratios)) if ratios else float("nan")}


def tabular_env_kwargs(size: int) -> dict:
    """The bundled map on the paper's area grid of ``size`` cells (a coarse safe grid would close its narrow
    passages), a random start each episode, D-CRF (Eq. 2) as the continuous reward."""
    sample = bundled_sample()
    env = gym.make(ENV_ID, map=sample.grid_map, start=sample.start, goal=sample.goal, size=size,
                   grid_rule="area").unwrapped
    return {"map": sample.grid_map, "start": sample.start, "goal": sample.goal, "size": size, "grid_rule": "area",
            "r_c": d_crf(env.blocked.shape, env.goal), "random_start": True}


def train_and_score(name: str, env_id: str, kwargs: dict, policy: str, args: argparse.Namespace,
                    eval_seed: int) -> dict:
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.logger import Logger

    vec = make_vec_env(env_id, n_envs=args.n_envs, seed=args.seed, env_kwargs=kwargs)
    # gamma 0.95 as in the paper's Q-learning: with D-CRF, r_max / (1 - gamma) = 100 keeps the per-cell
    # rewards from outweighing the goal (at 0.99 agents learn to wander; docs/method.md, Eq. 2)
    model = PPO(policy, vec, n_steps=args.n_steps, batch_size=args.batch_size, gamma=0.95, ent_coef=0.01,
                learning_rate=3e-4, seed=args.seed, device="cpu", verbose=0)
    model.set_logger(Logger(folder=None, output_formats=[]))  # SB3's default logger leaves an empty SB3-<time> folder in /tmp
    t0 = time.perf_counter()
    model.learn(total_timesteps=args.timesteps, progress_bar=args.progress)
    seconds = time.perf_counter() - t0
    scores = evaluate(model, gym.make(env_id, **kwargs), args.eval_episodes, eval_seed)
    return {"env": name, "timesteps": args.timesteps, "seconds": seconds, **scores}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--env", choices=("tabular", "random", "both"), default="both")
    p.add_argument("--timesteps", type=int, default=200_000, help="training steps per env (default: 200,000)")
    p.add_argument("--map-size", type=int, default=16, help="GridPath-v0: cells on the bundled map's side (default: 16)")
    p.add_argument("--size", type=int, default=12, help="GridPathRandom-v0: cells on a side (default: 12)")
    p.add_argument("--n-envs", type=int, default=4, help="vector-env copies (default: 4)")
    p.add_argument("--n-steps", type=int, default=256, help="PPO rollout length per copy (default: 256)")
    p.add_argument("--batch-size", type=int, default=256)
    p.add_argument("--eval-episodes", type=int, default=100, help="greedy episodes scored (default: 100)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--threads", type=int, default=1, help="torch threads (default: 1)")
    p.add_argument("--progress", action="store_true", help="show a progress bar while training")
    p.add_argument("--quick", action="store_true", help="a smoke run: 2,048 steps, 10 evaluation episodes")
    args = p.parse_args(argv)
    if args.quick:
        args.timesteps, args.eval_episodes, args.n_steps, args.batch_size = 2048, 10, 128, 128
    import torch

    torch.set_num_threads(args.threads)
    warnings.filterwarnings("ignore", message=".*moved to the nearest free cell")  # the bundled start at 16 cells
    rows = []
    if args.env in ("tabular", "both"):
        rows.append(train_and_score("GridPath-v0 (bundled map)", ENV_ID, tabular_env_kwargs(args.map_size), "MlpPolicy",
                                    args, eval_seed=0))
    if args.env in ("random", "both"):
        kwargs = {"size": args.size, "view": "ego", "view_size": 7, "continuous_reward": "d-crf"}
        rows.append(train_and_score("GridPathRandom-v0 (unseen maps)", RANDOM_ENV_ID, kwargs, "MultiInputPolicy",
                                    args, eval_seed=10**6))
    print(f"{'env':<34} {'steps':>9} {'train s':>8} {'success':>8} {'moves / A*':>11}")
    for r in rows:
        print(f"{r['env']:<34} {r['timesteps']:>9,} {r['seconds']:>8.1f} {r['success']:>8.0%} {r['ratio']:>11.2f}")
    print("A* (reference)                     succeeds on every problem; moves / A* = 1.00 by definition")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
