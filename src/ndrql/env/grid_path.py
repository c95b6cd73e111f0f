"""``ndrql/GridPath-v0``: the tabular Q-learning problem of the NDR-QL paper (Eq. 1) as a Gymnasium environment."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ndrql.env.args import (check_cell_px, check_frame, check_grid_shape, check_point, check_rewards, check_seed,
                             check_size, reset_options)
from ndrql.env.render import render_rgb, render_text
from ndrql.env.sources import GRID_RULES, EnvProblem, grid_problem, map_problem
from ndrql.errors import NdrqlError, PointError
from ndrql.maps.grid import PLANNING_SIZE, GridMap, bfs_distances
from ndrql.pipeline.problem import read_map
from ndrql.planning import rules
from ndrql.planning.config import QLConfig

#: Built-in map used when no grid is given: ``#`` blocked, ``.`` free; start top-left, goal bottom-right.
DEFAULT_MAP: tuple[str, ...] = (
    "........",
    ".##.....",
    "..#..##.",
    "..#...#.",
    "..###.#.",
    "......#.",
    ".####...",
    "........",
)

#: Reset options :class:`GridPathEnv` understands.
RESET_OPTIONS = ("map", "grid", "start", "goal")

MapLike = str | Path | GridMap | np.ndarray


def _parse_map(rows: tuple[str, ...] | list[str]) -> np.ndarray:
    return np.array([[ch == "#" for ch in row] for row in rows], dtype=bool)


class GridPathEnv(gym.Env):
    """Grid path planning with the rewards of the NDR-QL paper (Eq. 1): the tabular Q-learning problem.

    ## Description
    An agent moves on a 4-connected planning grid from a start cell to a goal cell. The rules are
    those of the compiled Q-learning kernel, from their one definition in :mod:`ndrql.planning.rules`
    (see ``docs/method.md``). The observation is the cell alone, as in tabular Q-learning: the
    revisit penalty depends on the cells visited in this episode, which it does not show (the
    goal-conditioned ``ndrql/GridPathRandom-v0`` observes them).

    ## Action Space
    ``Discrete(4)``: 0 up (row - 1), 1 down (row + 1), 2 left (col - 1), 3 right (col + 1).

    ## Observation Space
    ``Discrete(h * w)``: the agent's cell as ``row * w + col`` on the ``h x w`` planning grid.

    ## Starting State
    The start cell. With ``random_start=True``, a free cell drawn uniformly (from
    ``self.np_random``) among those 4-connected to the goal, other than the goal.

    ## Reward
    - -10 for moving into an obstacle or off the grid (the agent stays where it is);
    - +40 for reaching the goal;
    - -5 for moving into a cell already visited in this episode;
    - ``r_c[row, col]`` of the cell entered otherwise (0 for plain Q-learning; see
      :mod:`ndrql.planning.priors` for the paper's continuous rewards, Eqs. 2-4).

    ## Episode End
    Terminated when the agent reaches the goal. Truncated after ``max_steps`` moves (default
    ``4 * h * w``, as in training). ``gym.make`` adds a ``TimeLimit`` of 10,000 steps
    (``spec.max_episode_steps``): the same cap for the paper's 50x50 grid, never earlier for a smaller
    one; for a larger grid pass ``max_episode_steps=4 * h * w`` to ``gym.make``.

    ## Arguments
    - ``map``: a map file (image, ROS ``map_server`` YAML, MovingAI ``.map``, ``.npy``), a ``GridMap``
      or a bool array in pixels; it becomes the planning grid ``ndrql plan`` builds: by default the
      safe grid (square cells, a cell blocked when any pixel is an obstacle, so thin walls stay walls)
      at ``size="auto"`` (the coarsest that keeps the route; the size it picks is kept for later
      resets, ``env.size``), obstacles inflated by ``robot_radius`` (metres on maps with a resolution,
      else pixels); ``grid_rule="area"`` gives the paper's 50x50 area grid (``size`` cells);
      ``start``/``goal`` are then ``(row, col)`` map pixels and required; ``env.grid_rule`` and
      ``env.size`` name the grid;
    - ``grid``: a planning grid given directly, bool ``(h, w)``, ``True`` = blocked (default
      :data:`DEFAULT_MAP`, 8x8, when neither ``map`` nor ``grid`` is given); ``start``/``goal`` are
      then ``(row, col)`` cells (default top-left and bottom-right);
    - ``r_c``: ``(h, w)`` continuous reward (default zeros);
    - ``config``: :class:`~ndrql.planning.config.QLConfig` for the reward constants and ``max_steps``;
    - ``random_start``: draw the start cell at each reset;
    - ``render_mode``: ``"ansi"`` (text: ``#`` blocked, ``S``/``G`` start/goal, ``A`` agent,
      ``*`` visited) or ``"rgb_array"`` (``cell_px`` pixels per cell).

    ``reset(options=...)`` takes ``map`` or ``grid`` (a new problem of the same grid shape: the
    observation space is fixed) and ``start``/``goal`` (map pixels when the env has a map, else
    cells); points not given are kept.

    ``info`` holds ``cell`` (row, col), ``outcome`` (``reset``, ``move``, ``collision``,
    ``revisit``, ``goal``) and ``steps``; after a reset also ``start`` (this episode's start cell),
    ``goal`` and ``astar_length`` (moves of a shortest path from it).
    """

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 4}

    def __init__(
        self,
        grid: np.ndarray | None = None,
        start: tuple[int, int] | None = None,
        goal: tuple[int, int] | None = None,
        r_c: np.ndarray | None = None,
        config: QLConfig | None = None,
        random_start: bool = False,
        render_mode: str | None = None,
        cell_px: int = 8,
        map: MapLike | None = None,  # noqa: A002  (the name users pass to gym.make)
        size: int | str | None = None,
        grid_rule: str | None = None,
        robot_radius: float = 0.0,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise NdrqlError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        if grid_rule is not None and grid_rule not in GRID_RULES:
            raise NdrqlError(f"unknown grid_rule {grid_rule!r}; valid: {', '.join(GRID_RULES)}")
        if map is not None and grid is not None:
            raise NdrqlError("give either map (pixels) or grid (planning cells), not both")
        if map is None and (size is not None or grid_rule is not None or robot_radius):
            raise NdrqlError("size, grid_rule and robot_radius turn a map into a grid: give map (or drop them)")
        # a map file plans on the grid `ndrql plan` builds: safe, size auto (fixed at reset for the same shape)
        self.grid_rule = grid_rule or "safe"
        if size is not None and not (isinstance(size, str) and size.strip().lower() == "auto"):
            size = check_size(size)  # the bounds every command shares
        self.size: int | str = size if size is not None else ("auto" if self.grid_rule == "safe" else PLANNING_SIZE)
        self.robot_radius = float(robot_radius)
        self.config = config or QLConfig()
        start, goal = check_point(start, "start"), check_point(goal, "goal")
        cell_px = check_cell_px(cell_px)
        check_grid_shape(grid)
        self.problem = self._new_problem(map, grid, start, goal, None)
        if render_mode == "rgb_array":
            check_frame(cell_px, self.problem.blocked.shape)
        h, w = self.problem.blocked.shape
        self.r_c = np.zeros((h, w)) if r_c is None else np.asarray(r_c, dtype=np.float64)
        if self.r_c.shape != (h, w):
            raise NdrqlError(f"r_c must have the grid's shape {(h, w)}, got {self.r_c.shape}")
        self._r_flat = np.ascontiguousarray(check_rewards(self.r_c)).ravel()
        self.random_start = bool(random_start)
        self.render_mode = render_mode
        self.cell_px = int(cell_px)
        self.max_steps = self.config.steps_cap(h * w)
        self.observation_space = spaces.Discrete(h * w)
        self.action_space = spaces.Discrete(rules.N_ACTIONS)
        self._visited = np.zeros(h * w, dtype=np.int64)
        self._mark = 0
        self._steps = 0
        self._use_problem(self.problem)

    # -- the problem -----------------------------------------------------------------------------

    _map: GridMap | None = None

    def _fix_size(self, problem: EnvProblem) -> EnvProblem:
        """Keep the size ``auto`` chose for later problems on this map (the observation space is fixed)."""
        if problem.grid_size is not None:
            self.size = problem.grid_size
        return problem

    def _new_problem(self, map_: MapLike | None, grid: np.ndarray | None, start, goal,
                     old: EnvProblem | None) -> EnvProblem:
        """The problem for a map (pixels) or a grid (cells); points default to ``old``'s (or the corners)."""
        if map_ is not None:
            source = old.source if old is not None else None
            start = start if start is not None else (source.start if source is not None else None)
            goal = goal if goal is not None else (source.goal if source is not None else None)
            if start is None or goal is None:
                raise PointError("a map needs start and goal, (row, col) in map pixels")
            self._map = read_map(map_)  # read once: new points on this map reuse it (and its resolution)
            return self._fix_size(map_problem(self._map, start, goal, self.size, self.grid_rule,
                                              robot_radius=self.robot_radius, name=_name(map_, self._map)))
        if grid is None and old is not None and old.source is not None:  # new points on the same map
            return map_problem(self._map, start if start is not None else old.source.start,
                               goal if goal is not None else old.source.goal, self.size, self.grid_rule,
                               robot_radius=self.robot_radius, name=old.name)
        if grid is None:
            blocked = old.blocked if old is not None else _parse_map(DEFAULT_MAP)
        else:
            blocked = np.asarray(grid, dtype=bool)
        if blocked.ndim != 2 or blocked.size == 0:
            raise NdrqlError(f"grid must be a non-empty 2-D bool array, got shape {blocked.shape}")
        h, w = blocked.shape
        keep = old is not None and old.blocked.shape == blocked.shape
        start = start if start is not None else (old.start if keep else (0, 0))
        goal = goal if goal is not None else (old.goal if keep else (h - 1, w - 1))
        return grid_problem(blocked, start, goal)

    def _use_problem(self, problem: EnvProblem) -> None:
        self.problem = problem
        self.blocked = problem.blocked
        self.start = problem.start
        self.goal = problem.goal
        self.nxt = rules.next_table(self.blocked)
        self._start_choices: np.ndarray | None = None
        self._goal_dist: np.ndarray | None = None
        self._s = rules.cell_index(self.start, self.width)

    @property
    def width(self) -> int:
        return int(self.blocked.shape[1])

    def _reachable_starts(self) -> np.ndarray:
        if self._start_choices is None:
            from scipy import ndimage

            labels, _ = ndimage.label(~self.blocked, structure=ndimage.generate_binary_structure(2, 1))
            same = (labels == labels[self.goal]).ravel()
            same[rules.cell_index(self.goal, self.width)] = False
            self._start_choices = np.flatnonzero(same)
        return self._start_choices

    def _astar_length(self) -> int:
        """Moves of a shortest path from the agent's cell to the goal (4-connected BFS from the goal, cached)."""
        if self._goal_dist is None:
            self._goal_dist = bfs_distances(self.blocked, self.goal)
        return int(self._goal_dist[rules.index_cell(self._s, self.width)])

    def _info(self, outcome: str) -> dict[str, Any]:
        return {"cell": rules.index_cell(self._s, self.width), "outcome": outcome, "steps": self._steps}

    # -- the Gymnasium API -----------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        check_seed(seed)
        super().reset(seed=seed)
        opts = reset_options(options, RESET_OPTIONS)
        if opts:
            check_grid_shape(opts.get("grid"))
            if "map" in opts and "grid" in opts:
                raise NdrqlError("give either map or grid in the reset options, not both")
            problem = self._new_problem(opts.get("map"), opts.get("grid"), opts.get("start"), opts.get("goal"),
                                        self.problem)
            if problem.blocked.shape != self.blocked.shape:
                raise NdrqlError(f"the new planning grid is {problem.blocked.shape[0]}x{problem.blocked.shape[1]}; "
                                 f"this env's observation space is for {self.blocked.shape[0]}x{self.blocked.shape[1]} "
                                 f"(make a new env for another shape)")
            self._use_problem(problem)
        if self.random_start:
            choices = self._reachable_starts()
            self._s = int(choices[self.np_random.integers(len(choices))])
        else:
            self._s = rules.cell_index(self.start, self.width)
        self._mark += 1
        self._visited[self._s] = self._mark
        self._steps = 0
        info = self._info("reset")
        info.update(start=rules.index_cell(self._s, self.width), goal=self.goal, astar_length=self._astar_length())
        return int(self._s), info

    def step(self, action):
        if not self.action_space.contains(action):
            raise NdrqlError(f"invalid action {action!r}; valid: 0..3 (up, down, left, right)")
        cfg = self.config
        s2, r, outcome = rules.step(
            self.nxt,
            rules.cell_index(self.goal, self.width),
            self._r_flat,
            self._visited,
            self._mark,
            self._s,
            int(action),
            cfg.reward_collision,
            cfg.reward_goal,
            cfg.reward_revisit,
        )
        self._s = int(s2)
        self._steps += 1
        terminated = outcome == rules.GOAL
        truncated = (not terminated) and self._steps >= self.max_steps
        return int(self._s), float(r), bool(terminated), bool(truncated), self._info(rules.OUTCOME_NAMES[outcome])

    def _visited_grid(self) -> np.ndarray:
        return (self._visited == self._mark).reshape(self.blocked.shape)

    def render(self):
        agent = rules.index_cell(self._s, self.width)
        if self.render_mode == "ansi":
            return render_text(self.blocked, self._visited_grid(), agent, self.start, self.goal)
        if self.render_mode == "rgb_array":
            return render_rgb(self.blocked, self._visited_grid(), agent, self.start, self.goal, self.cell_px)
        return None


def _name(given: Any, grid_map: GridMap) -> str:
    """What a problem on a map is called: the file as given, else the map's own name."""
    return str(given) if isinstance(given, (str, Path)) else (grid_map.source or "map")
