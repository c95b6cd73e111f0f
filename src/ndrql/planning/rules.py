"""The Q-learning problem of docs/method.md (paper Eq. 1), defined once.

The compiled kernel (:mod:`ndrql.planning.kernel`), the numpy reference
(:mod:`ndrql.planning.reference`) and the Gymnasium environment (:mod:`ndrql.env`) all use the
functions below: :func:`next_table` fixes where each action leads, :func:`step` fixes the reward,
the visited-cell bookkeeping and termination, :func:`q_update` the learning rule and
:func:`greedy_streak` when a run has converged. :func:`step`, :func:`greedy_action`, :func:`max_q`
and :func:`greedy_streak` are written in the subset of Python that numba compiles; the kernel
compiles these very functions (and inlines :func:`q_update`, which the reference calls).

States are flat cell indices ``s = row * W + col`` of the planning grid. Obstacle cells are never
states; their rows of the transition table point to themselves.
"""

from __future__ import annotations

import numpy as np

#: Action deltas ``(d_row, d_col)`` in action order: 0 up, 1 down, 2 left, 3 right.
ACTIONS: tuple[tuple[int, int], ...] = ((-1, 0), (1, 0), (0, -1), (0, 1))
#: Human-readable action names, in action order.
ACTION_NAMES: tuple[str, ...] = ("up", "down", "left", "right")
N_ACTIONS = 4

#: Eq. 1, scenario 1: moving into an obstacle or off the map (the agent stays, the episode goes on).
REWARD_COLLISION = -10.0
#: Eq. 1, scenario 2: reaching the goal (the episode ends).
REWARD_GOAL = 40.0
#: Eq. 1, scenario 3: moving into a cell already visited in this episode.
REWARD_REVISIT = -5.0

#: Outcome codes returned by :func:`step`.
MOVE, COLLISION, REVISIT, GOAL = 0, 1, 2, 3
OUTCOME_NAMES: tuple[str, ...] = ("move", "collision", "revisit", "goal")


def next_table(blocked: np.ndarray) -> np.ndarray:
    """Transition table ``nxt[s, a]``: the cell action ``a`` leads to from cell ``s`` (docs/method.md).

    A move off the map or into an obstacle leaves the agent where it is (``nxt[s, a] == s``).
    ``blocked`` is a bool ``(H, W)`` array, ``True`` = obstacle. Returns int32 ``(H * W, 4)``.
    Built by shifting the grid of cell indices one cell per action (O(cells), a few ms on 600 x 600 cells).
    """
    blocked = np.asarray(blocked, dtype=bool)
    if blocked.ndim != 2:
        raise ValueError(f"blocked must be a 2-D bool array, got shape {blocked.shape}")
    h, w = blocked.shape
    cells = np.arange(h * w, dtype=np.int32).reshape(h, w)
    nxt = np.empty((h, w, N_ACTIONS), dtype=np.int32)
    nxt[...] = cells[:, :, None]  # off the map or blocked: stay
    for a, (dr, dc) in enumerate(ACTIONS):
        src = (slice(max(0, -dr), h - max(0, dr)), slice(max(0, -dc), w - max(0, dc)))  # cells whose move stays on
        dst = (slice(max(0, dr), h - max(0, -dr)), slice(max(0, dc), w - max(0, -dc)))  # ... and where it lands
        out = nxt[src + (a,)]
        np.copyto(out, cells[dst], where=~blocked[dst])
    return nxt.reshape(h * w, N_ACTIONS)


def step(nxt, goal, r_c, visited, mark, s, a, r_collision, r_goal, r_revisit):
    """Eq. 1: one move from cell ``s`` with action ``a``; returns ``(s_next, reward, outcome)``.

    - blocked or off the map: ``r_collision``, the agent stays (``s_next == s``), outcome ``COLLISION``;
    - the goal: ``r_goal``, outcome ``GOAL`` (the episode ends);
    - a cell with ``visited[cell] == mark`` (already visited this episode): ``r_revisit``;
    - any other cell: ``r_c[cell]``, outcome ``MOVE``.

    The target cell is then marked visited (``visited[s_next] = mark``). ``r_c`` is flat
    (``H * W``); ``mark`` identifies the current episode so ``visited`` need not be cleared.
    Written as selects rather than early returns so the compiled kernel has no hard-to-predict
    branches here; the precedence is collision, goal, revisit, move.
    """
    s2 = nxt[s, a]
    revisit = visited[s2] == mark
    visited[s2] = mark
    r = r_c[s2]
    outcome = MOVE
    if revisit:
        r = r_revisit
        outcome = REVISIT
    if s2 == goal:
        r = r_goal
        outcome = GOAL
    if s2 == s:
        r = r_collision
        outcome = COLLISION
    return s2, r, outcome


def greedy_action(q, s):
    """``argmax_a q[s, a]`` with ties broken by the lowest action index (docs/method.md rollouts)."""
    best = 0
    v = q[s, 0]
    for a in range(1, 4):
        if q[s, a] > v:
            v = q[s, a]
            best = a
    return best


def max_q(q, s):
    """``max_a q[s, a]``, the bootstrap target of the update (a pairwise tree: shorter latency)."""
    a = q[s, 0]
    b = q[s, 1]
    c = q[s, 2]
    d = q[s, 3]
    ab = a if a >= b else b
    cd = c if c >= d else d
    return ab if ab >= cd else cd


def q_update(q, s, a, r, s2, terminal, alpha, gamma):
    """Q-update (docs/method.md): ``Q(s, a) += alpha * (r + gamma * max_a' Q(s', a') - Q(s, a))`` after the
    move ``s -a-> s2`` with reward ``r``; without the bootstrap term when the move ends the episode
    (``terminal``: it reached the goal)."""
    if terminal:
        q[s, a] += alpha * (r - q[s, a])
    else:
        q[s, a] += alpha * (r + gamma * max_q(q, s2) - q[s, a])


def greedy_streak(streak, path, length, best, best_len):
    """Convergence (docs/method.md): episodes in a row whose greedy rollout reached the goal on one same path.

    ``path[0..length]`` is this episode's rollout (``length == -1``: it failed), ``best[0..best_len]``
    the last rollout that reached the goal, ``streak`` the count before this episode. Returns the
    new count: 0 after a failed rollout, ``streak + 1`` when the path repeats ``best``, else 1 (the
    caller then keeps ``path`` as the new ``best``). A run has converged once the count reaches the
    window ``W``. Paths may be lists or arrays of flat cell indices.
    """
    if length < 0:
        return 0
    if length != best_len:
        return 1
    for i in range(length + 1):
        if path[i] != best[i]:
            return 1
    return streak + 1


def cell_index(cell, width: int) -> int:
    """Flat index of ``(row, col)``."""
    return int(cell[0]) * int(width) + int(cell[1])


def index_cell(s: int, width: int) -> tuple[int, int]:
    """``(row, col)`` of a flat index."""
    return int(s) // int(width), int(s) % int(width)
