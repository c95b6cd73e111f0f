"""``ndrql/GridPathRandom-v0``: goal-conditioned grid path planning on a new map every episode."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ndrql.env.args import check_cell_px, check_frame, check_map_px, check_seed, check_size, reset_options
from ndrql.env.observe import (CHANNELS, PRIOR_CHANNELS, PRIORS, VIEWS, ego_view, full_view, goal_vector,
                               grid_image, ndr_prior, oracle_prior)
from ndrql.env.render import render_rgb, render_text
from ndrql.env.sources import GRID_RULES, DatasetSource, EnvProblem, GeneratorSource, map_problem
from ndrql.errors import NdrqlError
from ndrql.model.predict import Predictor
from ndrql.model.symmetry import DEFAULT_COUNT, check_count
from ndrql.planning import priors, rules
from ndrql.planning.config import PriorConfig, QLConfig

#: Continuous rewards ``r_c``: none (Eq. 1 alone), D-CRF (Eq. 2) or NDR-CRF mixed with D-CRF (Eq. 4, needs a prior).
CONTINUOUS_REWARDS = ("none", "d-crf", "ndr")
#: Where maps come from.
SOURCES = ("generator", "dataset")
#: Reset options :class:`GoalGridPathEnv` understands (one episode on this map, then back to the source).
RESET_OPTIONS = ("map", "start", "goal")


class GoalGridPathEnv(gym.Env):
    """Goal-conditioned grid path planning: one policy for many maps, Eq. 1's rewards.

    ## Description
    Every episode draws a planning problem (a map, downscaled to a planning grid, with a start and a
    goal cell that are free and 4-connected) from ``source`` using ``self.np_random`` only, so
    ``reset(seed=s)`` fixes the map too. The moves and rewards are those of ``ndrql/GridPath-v0``
    and of the Q-learning kernel (:mod:`ndrql.planning.rules`); unlike it, the observation shows the
    map, the goal and the cells visited in this episode, so the revisit penalty is observable.

    ## Action Space
    ``Discrete(4)``: 0 up (row - 1), 1 down (row + 1), 2 left (col - 1), 3 right (col + 1).

    ## Observation Space
    ``Dict``:
    - ``image``: ``Box(0, 1, (C, V, V), float32)``, channels ``obstacle``, ``visited``, ``agent``,
      ``goal`` and, with a ``prior``, ``region`` and ``guideline`` (the NDR model's or the oracle's
      probabilities averaged onto each cell) and, with ``prior_distance``, ``distance`` (the goal
      distance ``d`` in cells as ``d / (d + size)``: the model's distance head or the oracle's exact
      moves). ``view="full"``: the whole grid, ``V = size``
      (padded with obstacles); ``view="ego"``: a ``V = view_size`` window centred on the agent
      (off-grid cells are obstacles).
    - ``goal``: ``Box(-1, 1, (2,), float32)``, ``(goal - agent) / size`` in rows and columns.

    ## Starting State
    The drawn problem's start cell.

    ## Reward
    -10 for a move into an obstacle or off the grid (the agent stays), +40 for reaching the goal,
    -5 for entering a cell visited in this episode, else ``r_c`` of the cell entered:
    0 (``continuous_reward="none"``), D-CRF (``"d-crf"``, Eq. 2) or Eq. 4's mix of NDR-CRF and
    D-CRF (``"ndr"``, needs a prior).

    ## Episode End
    Terminated at the goal; truncated after ``max_steps`` moves (default ``4 * size * size``, the
    registered ``max_episode_steps`` for the default size).

    ## Arguments
    - ``source``: ``"generator"`` (procedural families, :mod:`ndrql.synth.families`), ``"dataset"``
      (the path-planning dataset at ``data``, split ``split``, with its own start and goal) or any
      object with ``draw(rng) -> EnvProblem``;
    - ``size``: planning-grid cells on a side (default 16); ``grid_rule``: ``area`` (the paper's)
      or ``safe``;
    - ``families``, ``map_px``: the generator's families (default all) and map side in pixels
      (default ``4 * size``);
    - ``data``, ``split``: the dataset root in its original layout and ``train``/``seen``/``unseen``;
    - ``view`` (``full``/``ego``), ``view_size`` (odd, default 7);
    - ``prior``: ``none``, ``ndr`` (the NDR model, loaded on first use from ``weights`` or the
      shipped model; a forward pass per episode, averaged over ``symmetries`` orientations of the
      grid, ``ndrql plan``'s 4 by default) or ``oracle``; ``prior_distance``: add the goal-distance channel;
    - ``continuous_reward``: ``none``, ``d-crf`` or ``ndr``; ``prior_config``: the constants of Eqs. 2-4;
    - ``config``: :class:`~ndrql.planning.config.QLConfig` (reward constants, ``max_steps``);
    - ``render_mode``: ``"ansi"`` or ``"rgb_array"`` (``cell_px`` pixels per cell).

    ``reset(options={"map": ..., "start": ..., "goal": ...})`` plays one episode on that map (start
    and goal in map pixels; the grid must fit the view) and then draws from the source again.
    ``info`` after a reset holds ``start``, ``goal``, ``astar_length`` (moves of a shortest path)
    and ``map`` (where the problem came from); after a step ``cell``, ``outcome`` and ``steps``.
    """

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 4}

    def __init__(
        self,
        source: str | Any = "generator",
        size: int = 16,
        grid_rule: str = "area",
        families: tuple[str, ...] | list[str] | None = None,
        map_px: int | None = None,
        data: str | Path | None = None,
        split: str = "train",
        view: str = "full",
        view_size: int = 7,
        prior: str = "none",
        weights: str | Path | None = None,
        symmetries: int = DEFAULT_COUNT,
        prior_distance: bool = False,
        continuous_reward: str = "none",
        prior_config: PriorConfig | None = None,
        config: QLConfig | None = None,
        render_mode: str | None = None,
        cell_px: int = 8,
    ) -> None:
        for name, value, valid in (("view", view, VIEWS), ("prior", prior, PRIORS), ("grid_rule", grid_rule, GRID_RULES),
                                   ("continuous_reward", continuous_reward, CONTINUOUS_REWARDS)):
            if value not in valid:
                raise NdrqlError(f"unknown {name} {value!r}; valid: {', '.join(valid)}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise NdrqlError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        if continuous_reward == "ndr" and prior == "none":
            raise NdrqlError("continuous_reward='ndr' (Eq. 4) needs prior='ndr' or prior='oracle'")
        if prior_distance and prior == "none":
            raise NdrqlError("prior_distance needs prior='ndr' or prior='oracle'")
        check_count(symmetries, NdrqlError)
        if view == "ego" and (int(view_size) < 3 or int(view_size) % 2 == 0):
            raise NdrqlError(f"view_size must be an odd number >= 3, got {view_size}")
        self.size = check_size(size)
        self.grid_rule = grid_rule
        cell_px = check_cell_px(cell_px)
        if render_mode == "rgb_array":
            check_frame(cell_px, (self.size, self.size))
        map_px = check_map_px(map_px, self.size)
        self.source = self._make_source(source, families, map_px, data, split)
        self.view = view
        self.view_size = int(view_size) if view == "ego" else self.size
        self.prior = prior
        self.weights = weights
        self.symmetries = int(symmetries)
        self.prior_distance = bool(prior_distance)
        self.continuous_reward = continuous_reward
        self.prior_config = prior_config or PriorConfig()
        self.config = config or QLConfig()
        self.render_mode = render_mode
        self.cell_px = int(cell_px)
        self.max_steps = self.config.steps_cap(self.size * self.size)
        n = len(CHANNELS) + (0 if prior == "none" else len(PRIOR_CHANNELS) + int(self.prior_distance))
        v = self.view_size
        self.observation_space = spaces.Dict({
            "image": spaces.Box(0.0, 1.0, (n, v, v), dtype=np.float32),
            "goal": spaces.Box(-1.0, 1.0, (2,), dtype=np.float32),
        })
        self.action_space = spaces.Discrete(rules.N_ACTIONS)
        self._predictor: Any = None
        self.problem: EnvProblem | None = None

    def _make_source(self, source: str | Any, families, map_px, data, split) -> Any:
        if hasattr(source, "draw"):
            return source
        if source == "generator":
            return GeneratorSource(None if families is None else tuple(families),
                                   int(map_px) if map_px is not None else 4 * self.size, self.size, self.grid_rule)
        if source == "dataset":
            if data is None:
                raise NdrqlError("source='dataset' needs data=DATASET_DIR (the folder holding TRAIN and TEST)")
            return DatasetSource(data, split, self.size, self.grid_rule)
        raise NdrqlError(f"unknown source {source!r}; valid: {', '.join(SOURCES)} or an object with draw(rng)")

    # -- one problem -----------------------------------------------------------------------------

    def _prior(self, problem: EnvProblem) -> np.ndarray | None:
        if self.prior == "oracle":
            return oracle_prior(problem, self.size if self.prior_distance else None)
        if self.prior == "ndr":
            if self._predictor is None:
                self._predictor = Predictor.load(self.weights, threads=1, symmetries=self.symmetries)
            return ndr_prior(self._predictor, problem, self.grid_rule, self.size, self.prior_distance)
        return None

    def _r_c(self, problem: EnvProblem, prior: np.ndarray | None) -> np.ndarray:
        shape = problem.blocked.shape
        if self.continuous_reward == "d-crf":
            return priors.d_crf(shape, problem.goal, self.prior_config)
        if self.continuous_reward == "ndr" and prior is not None:
            return priors.mixed_crf(prior[1], problem.goal, self.prior_config)
        return np.zeros(shape)

    def _use(self, problem: EnvProblem) -> None:
        h, w = problem.blocked.shape
        if self.view == "full" and (h > self.size or w > self.size):
            raise NdrqlError(f"a {h}x{w} planning grid does not fit this env's {self.size}x{self.size} view")
        self.problem = problem
        self.nxt = rules.next_table(problem.blocked)
        self._prior_img = self._prior(problem)
        self._r_flat = np.ascontiguousarray(self._r_c(problem, self._prior_img), dtype=np.float64).ravel()
        self._visited = np.zeros(h * w, dtype=np.int64)
        self._w = w
        self._goal_idx = rules.cell_index(problem.goal, w)
        self._s = rules.cell_index(problem.start, w)
        self._visited[self._s] = 1
        self._steps = 0

    def _obs(self) -> dict[str, np.ndarray]:
        p = self.problem
        agent = rules.index_cell(self._s, self._w)
        visited = (self._visited == 1).reshape(p.blocked.shape)
        img = grid_image(p.blocked, visited, agent, p.goal, self._prior_img)
        img = full_view(img, self.size) if self.view == "full" else ego_view(img, agent, self.view_size)
        return {"image": img, "goal": goal_vector(agent, p.goal, self.size)}

    # -- the Gymnasium API -----------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        check_seed(seed)
        super().reset(seed=seed)
        opts = reset_options(options, RESET_OPTIONS)
        if opts:
            missing = [k for k in RESET_OPTIONS if k not in opts]
            if missing:
                raise NdrqlError(f"reset options need map, start and goal together (missing: {', '.join(missing)})")
            problem = map_problem(opts["map"], opts["start"], opts["goal"], self.size, self.grid_rule)
        else:
            problem = self.source.draw(self.np_random)
        self._use(problem)
        info = {"start": problem.start, "goal": problem.goal, "astar_length": problem.astar_length, "map": problem.name}
        return self._obs(), info

    def step(self, action):
        if self.problem is None:
            raise NdrqlError("call reset() before step()")
        if not self.action_space.contains(action):
            raise NdrqlError(f"invalid action {action!r}; valid: 0..3 (up, down, left, right)")
        cfg = self.config
        s2, r, outcome = rules.step(self.nxt, self._goal_idx, self._r_flat, self._visited, 1, self._s, int(action),
                                    cfg.reward_collision, cfg.reward_goal, cfg.reward_revisit)
        self._s = int(s2)
        self._steps += 1
        terminated = outcome == rules.GOAL
        truncated = (not terminated) and self._steps >= self.max_steps
        info = {"cell": rules.index_cell(self._s, self._w), "outcome": rules.OUTCOME_NAMES[outcome],
                "steps": self._steps}
        return self._obs(), float(r), bool(terminated), bool(truncated), info

    def render(self):
        if self.problem is None or self.render_mode is None:
            return None
        p = self.problem
        agent = rules.index_cell(self._s, self._w)
        visited = (self._visited == 1).reshape(p.blocked.shape)
        if self.render_mode == "ansi":
            return render_text(p.blocked, visited, agent, p.start, p.goal)
        return render_rgb(p.blocked, visited, agent, p.start, p.goal, self.cell_px)
