"""``ndrql/GridPath-v0``: the Q-learning problem of SPEC section 2 as a Gymnasium environment."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

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

_COLOURS = {
    "free": (255, 255, 255),
    "blocked": (40, 40, 40),
    "visited": (190, 215, 255),
    "start": (220, 40, 40),
    "goal": (40, 80, 220),
    "agent": (40, 170, 60),
}


def _parse_map(rows: tuple[str, ...] | list[str]) -> np.ndarray:
    return np.array([[ch == "#" for ch in row] for row in rows], dtype=bool)


class GridPathEnv(gym.Env):
    """Grid path planning with the rewards of the NDR-QL paper (Eq. 1).

    ## Description
    An agent moves on a 4-connected occupancy grid from a start cell to a goal cell. The rules are
    those of the compiled Q-learning kernel, from the one definition in
    :mod:`ndrql.planning.rules` (SPEC section 2).

    ## Action Space
    ``Discrete(4)``: 0 up (row - 1), 1 down (row + 1), 2 left (col - 1), 3 right (col + 1).

    ## Observation Space
    ``Discrete(H * W)``: the agent's cell as ``row * W + col``.

    ## Starting State
    The start cell. With ``random_start=True``, a free cell drawn uniformly (from
    ``self.np_random``) among those 4-connected to the goal, other than the goal.

    ## Reward
    - -10 for moving into an obstacle or off the map (the agent stays where it is);
    - +40 for reaching the goal;
    - -5 for moving into a cell already visited in this episode;
    - ``r_c[row, col]`` of the cell entered otherwise (0 for plain Q-learning; see
      :mod:`ndrql.planning.priors` for the paper's continuous rewards).

    ## Episode End
    Terminated when the agent reaches the goal. Truncated after ``max_steps`` moves
    (default ``4 * H * W``, as in training).

    ## Arguments
    - ``grid``: bool ``(H, W)`` array, ``True`` = blocked (default :data:`DEFAULT_MAP`, 8x8);
    - ``start``, ``goal``: ``(row, col)`` free cells (default top-left and bottom-right);
    - ``r_c``: ``(H, W)`` continuous reward (default zeros);
    - ``config``: :class:`~ndrql.planning.config.QLConfig` for the reward constants and ``max_steps``;
    - ``random_start``: draw the start cell at each reset;
    - ``render_mode``: ``"ansi"`` (text: ``#`` blocked, ``S``/``G`` start/goal, ``A`` agent,
      ``*`` visited) or ``"rgb_array"`` (``cell_px`` pixels per cell).

    ``info`` holds ``cell`` (row, col), ``outcome`` (``move``, ``collision``, ``revisit``, ``goal``)
    and ``steps``.
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
    ) -> None:
        blocked = _parse_map(DEFAULT_MAP) if grid is None else np.asarray(grid, dtype=bool)
        if blocked.ndim != 2 or blocked.size == 0:
            raise ValueError(f"grid must be a non-empty 2-D bool array, got shape {blocked.shape}")
        h, w = blocked.shape
        start = (0, 0) if start is None else (int(start[0]), int(start[1]))
        goal = (h - 1, w - 1) if goal is None else (int(goal[0]), int(goal[1]))
        for name, p in (("start", start), ("goal", goal)):
            if not (0 <= p[0] < h and 0 <= p[1] < w) or blocked[p]:
                raise ValueError(f"{name} {p} must be a free cell of the {h}x{w} grid")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        self.config = config or QLConfig()
        self.blocked = blocked.copy()
        self.start = start
        self.goal = goal
        self.r_c = np.zeros((h, w)) if r_c is None else np.asarray(r_c, dtype=np.float64)
        if self.r_c.shape != (h, w):
            raise ValueError(f"r_c must have the grid's shape {(h, w)}, got {self.r_c.shape}")
        self._r_flat = np.ascontiguousarray(self.r_c).ravel()
        self.random_start = bool(random_start)
        self.render_mode = render_mode
        self.cell_px = int(cell_px)
        self.max_steps = self.config.steps_cap(h * w)
        self.nxt = rules.next_table(self.blocked)
        self.observation_space = spaces.Discrete(h * w)
        self.action_space = spaces.Discrete(rules.N_ACTIONS)
        self._visited = np.zeros(h * w, dtype=np.int64)
        self._mark = 0
        self._steps = 0
        self._s = rules.cell_index(start, w)
        self._start_choices: np.ndarray | None = None

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

    def _info(self, outcome: str) -> dict[str, Any]:
        return {"cell": rules.index_cell(self._s, self.width), "outcome": outcome, "steps": self._steps}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        if self.random_start:
            choices = self._reachable_starts()
            self._s = int(choices[self.np_random.integers(len(choices))])
        else:
            self._s = rules.cell_index(self.start, self.width)
        self._mark += 1
        self._visited[self._s] = self._mark
        self._steps = 0
        return int(self._s), self._info("reset")

    def step(self, action):
        if not self.action_space.contains(action):
            raise ValueError(f"invalid action {action!r}; valid: 0..3 (up, down, left, right)")
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
        if self.render_mode == "ansi":
            return self._render_text()
        if self.render_mode == "rgb_array":
            return self._render_rgb()
        return None

    def _render_text(self) -> str:
        visited = self._visited_grid()
        agent = rules.index_cell(self._s, self.width)
        lines = []
        for r in range(self.blocked.shape[0]):
            row = []
            for c in range(self.blocked.shape[1]):
                if (r, c) == agent:
                    ch = "A"
                elif (r, c) == self.goal:
                    ch = "G"
                elif (r, c) == self.start:
                    ch = "S"
                elif self.blocked[r, c]:
                    ch = "#"
                elif visited[r, c]:
                    ch = "*"
                else:
                    ch = "."
                row.append(ch)
            lines.append("".join(row))
        return "\n".join(lines) + "\n"

    def _render_rgb(self) -> np.ndarray:
        h, w = self.blocked.shape
        img = np.empty((h, w, 3), dtype=np.uint8)
        img[:] = _COLOURS["free"]
        img[self._visited_grid()] = _COLOURS["visited"]
        img[self.blocked] = _COLOURS["blocked"]
        img[self.start] = _COLOURS["start"]
        img[self.goal] = _COLOURS["goal"]
        img[rules.index_cell(self._s, w)] = _COLOURS["agent"]
        k = max(1, self.cell_px)
        return np.ascontiguousarray(np.repeat(np.repeat(img, k, axis=0), k, axis=1))
