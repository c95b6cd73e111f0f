"""Tabular Q-learning (docs/method.md) compiled with numba: the whole run in one call.

:func:`train` runs every episode (epsilon-greedy with random tie-breaking, the Q-update :func:`rules.q_update`,
visited-cell tracking per episode) and, after each episode, the deterministic greedy rollout that
decides convergence (docs/method.md). Nothing runs in Python per step or per episode. The reward and the
transition are :func:`ndrql.planning.rules.step` and convergence :func:`ndrql.planning.rules.greedy_streak`,
compiled here; the random stream is :mod:`ndrql.planning.rng` (xoshiro256** seeded by splitmix64),
compiled here too, so a run depends only on its seed, whatever else runs in the process.

Importing this module imports numba; compiled code is cached on disk (``cache=True``). This is the
reference: the C extension ``ndrql.maps._kernels`` holds a bit-identical port, built at install time,
which :mod:`ndrql.planning.compiled` runs instead when it is built (tested against this kernel on random
problems, ``tests/planning/test_c_kernels.py``).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ndrql.planning import rng, rules
from ndrql.planning.rules import GOAL

_step = nb.njit(cache=True)(rules.step)
_greedy_action = nb.njit(cache=True)(rules.greedy_action)
_max_q = nb.njit(cache=True)(rules.max_q)
_greedy_streak = nb.njit(cache=True)(rules.greedy_streak)
_seed_state = nb.njit(cache=True)(rng.state_from_seed)
_xoshiro = nb.njit(cache=True)(rng.xoshiro)

#: ``_SELECT[mask, j]``: the j-th set bit of a 4-bit action mask (the j-th candidate action).
_SELECT = np.array([[[b for b in range(4) if m >> b & 1][min(j, max(bin(m).count("1") - 1, 0))] if m else 0
                     for j in range(4)] for m in range(16)], dtype=np.int64)


@nb.njit(cache=True)
def _draws(seed, n):
    """``n`` raw draws for ``seed``, compiled (tests compare them with :func:`ndrql.planning.rng.next_u64`)."""
    st = _seed_state(seed)
    x0, x1, x2, x3 = st[0], st[1], st[2], st[3]
    out = np.empty(n, dtype=np.uint64)
    for i in range(n):
        out[i], x0, x1, x2, x3 = _xoshiro(x0, x1, x2, x3)
    return out


@nb.njit(cache=True)
def _rollout(q, nxt, start, goal, seen, rmark, path, max_moves):
    """Greedy rollout (ties -> lowest action). Fills ``path[0..L]``; returns ``L`` or -1 on failure.

    Fails on a revisit (a blocked move counts: the agent stays on a visited cell) or after
    ``max_moves`` moves without reaching the goal.
    """
    s = start
    seen[s] = rmark
    path[0] = s
    n = 0
    while n < max_moves:
        a = _greedy_action(q, s)
        s2 = nxt[s, a]
        if s2 == s or seen[s2] == rmark:
            return -1
        n += 1
        path[n] = s2
        if s2 == goal:
            return n
        seen[s2] = rmark
        s = s2
    return -1


@nb.njit(cache=True)
def _grown_int(a, cap, fill):
    """``a`` copied into a longer int64 array of ``cap`` entries, the new ones ``fill``."""
    out = np.full(cap, fill, dtype=np.int64)
    out[: a.size] = a
    return out


@nb.njit(cache=True)
def _grown_float(a, cap):
    out = np.zeros(cap, dtype=np.float64)
    out[: a.size] = a
    return out


@nb.njit(cache=True)
def _grown_bool(a, cap):
    out = np.zeros(cap, dtype=np.bool_)
    out[: a.size] = a
    return out


@nb.njit(cache=True, nogil=True)
def train(
    nxt,
    start,
    goal,
    r_c,
    q,
    seed,
    alpha,
    gamma,
    eps_thr,
    max_steps,
    max_episodes,
    window,
    r_collision,
    r_goal,
    r_revisit,
):
    """Run Q-learning until convergence or ``max_episodes``; ``q`` (cells, 4) is updated in place.

    Arguments: ``nxt`` from :func:`rules.next_table`; ``start``/``goal`` flat cell indices; ``r_c``
    flat per-cell rewards; ``eps_thr`` from :func:`ndrql.planning.rng.eps_threshold`.

    Returns ``(n_episodes, steps, returns, success, greedy_len, conv_episode, conv_steps, path_len,
    path)``: per-episode arrays (valid up to ``n_episodes``; they grow as the run goes), where
    ``greedy_len`` is the greedy rollout's length after the episode (-1 if it failed);
    ``conv_episode`` is the 0-based convergence episode (-1 if none), ``conv_steps`` the training
    steps summed up to and including it; ``path[0..path_len]`` the last successful greedy path
    (``path_len == -1`` if no rollout ever reached the goal).
    """
    cells = nxt.shape[0]
    st = _seed_state(seed)
    x0 = st[0]
    x1 = st[1]
    x2 = st[2]
    x3 = st[3]
    visited = np.zeros(cells, dtype=np.int32)
    seen = np.zeros(cells, dtype=np.int32)
    cur = np.empty(cells + 1, dtype=np.int64)
    best = np.empty(cells + 1, dtype=np.int64)
    cap = min(max_episodes, 1024)  # the records grow as the run goes: memory follows the episodes run, not the cap
    steps = np.zeros(cap, dtype=np.int64)
    returns = np.zeros(cap, dtype=np.float64)
    success = np.zeros(cap, dtype=np.bool_)
    greedy_len = np.full(cap, -1, dtype=np.int64)
    mask32 = np.uint64(0xFFFFFFFF)
    thr = np.uint64(eps_thr)
    best_len = -1
    streak = 0
    total = 0
    conv_episode = -1
    conv_steps = -1
    n_done = 0
    for ep in range(max_episodes):
        mark = ep + 1
        s = start
        visited[s] = mark
        ret = 0.0
        n = 0
        reached = False
        while n < max_steps:
            u, x0, x1, x2, x3 = _xoshiro(x0, x1, x2, x3)
            lo = u & mask32
            # Epsilon-greedy with random tie-breaking: the candidate actions are a 4-bit mask (all
            # four when exploring, else the tied maxima); one is picked uniformly with the low 32
            # bits of the draw (the same rule as ndrql.planning.reference).
            m = _max_q(q, s)
            t0 = np.int64(q[s, 0] == m)
            t1 = np.int64(q[s, 1] == m)
            t2 = np.int64(q[s, 2] == m)
            t3 = np.int64(q[s, 3] == m)
            mask = t0 | (t1 << 1) | (t2 << 2) | (t3 << 3)
            k = t0 + t1 + t2 + t3
            if (u >> np.uint64(32)) < thr:
                mask = 15
                k = 4
            if k == 1:  # a unique best action (most steps once Q has values): no draw needed
                a = 0 if t0 else (1 if t1 else (2 if t2 else 3))
            else:
                j = np.int64((lo * np.uint64(k)) >> np.uint64(32))
                a = _SELECT[mask, j]
            s2, r, outcome = _step(nxt, goal, r_c, visited, mark, s, a, r_collision, r_goal, r_revisit)
            n += 1
            ret += r
            if outcome == GOAL:  # the Q-update, rules.q_update, inlined
                q[s, a] += alpha * (r - q[s, a])
                reached = True
                break
            q[s, a] += alpha * (r + gamma * _max_q(q, s2) - q[s, a])
            s = s2
        if ep >= cap:
            cap = min(max_episodes, 2 * cap)
            steps = _grown_int(steps, cap, 0)
            returns = _grown_float(returns, cap)
            success = _grown_bool(success, cap)
            greedy_len = _grown_int(greedy_len, cap, -1)
        steps[ep] = n
        returns[ep] = ret
        success[ep] = reached
        total += n
        n_done = ep + 1
        length = _rollout(q, nxt, start, goal, seen, mark, cur, cells)
        greedy_len[ep] = length
        streak = _greedy_streak(streak, cur, length, best, best_len)
        if streak == 1:  # a new path (or the same one after a failed rollout): it becomes the best
            for i in range(length + 1):
                best[i] = cur[i]
            best_len = length
        if streak >= window:
            conv_episode = ep
            conv_steps = total
            break
    return n_done, steps, returns, success, greedy_len, conv_episode, conv_steps, best_len, best


def warm_up() -> None:
    """Load (or compile) every kernel now, e.g. before forking workers, so they inherit it."""
    blocked = np.zeros((1, 2), dtype=bool)
    train(rules.next_table(blocked), 0, 1, np.zeros(2), np.zeros((2, 4)), 0, 0.1, 0.95, 0, 8, 1, 1,
          -10.0, 40.0, -5.0)


def _dispatchers() -> list:
    """The compiled functions a plan runs: the map's A* and line tests, and Q-learning."""
    from ndrql.maps import astar_kernel, lines_kernel  # lazy: loads numba (this module already has)

    return [astar_kernel.astar8_kernel, lines_kernel._first_blocked, lines_kernel._shortcut, train]


def _index_path(dispatcher) -> str | None:
    """Where numba keeps the index of ``dispatcher``'s cached machine code (None: not cached on disk)."""
    cache = getattr(dispatcher, "_cache", None)
    cache_file = getattr(cache, "_cache_file", None)
    return getattr(cache_file, "_index_path", None)


def compile_notice() -> str | None:
    """One line saying that this run compiles the kernels, why, for how long and where they are kept; None
    when numba's disk cache already holds them (every run after the first).

    numba caches machine code beside the installed sources (``__pycache__``), or, when that folder is
    read-only (a system-wide install), under the user's cache folder (``~/.cache/numba``;
    ``NUMBA_CACHE_DIR`` moves it). The first run after an install or an upgrade compiles once.
    """
    import os

    missing = [p for p in map(_index_path, _dispatchers()) if p is not None and not os.path.exists(p)]
    if not missing:
        return None
    where = os.path.dirname(missing[0])
    return (f"compiling the planners' machine code (numba) on this first run after install: about 10-20 s, "
            f"once; later runs load it from {where}")
