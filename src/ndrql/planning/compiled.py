"""Q-learning's compiled kernel as the planners call it: the C extension when built, else numba's.

:func:`train` takes the arguments of :func:`ndrql.planning.kernel.train` and returns the same tuple,
bit for bit (tested on random problems), from the C kernel built at install time when
:mod:`ndrql.maps.native` picks it, else from numba's kernel, which stays the reference. With the C
kernel nothing compiles at run time and numba is never imported; :func:`warm_up` and
:func:`compile_notice` then have nothing to do.
"""

from __future__ import annotations

import numpy as np

from ndrql.maps.native import backend, c_kernels

__all__ = ["backend", "compile_notice", "draws", "train", "warm_up"]


def train(nxt: np.ndarray, start: int, goal: int, r_c: np.ndarray, q: np.ndarray, seed: int, alpha: float,
          gamma: float, eps_thr: int, max_steps: int, max_episodes: int, window: int, r_collision: float,
          r_goal: float, r_revisit: float) -> tuple:
    """A whole Q-learning run; ``q`` (cells, 4), float64 C-contiguous, is updated in place.

    Arguments and result as :func:`ndrql.planning.kernel.train`: ``(n_episodes, steps, returns, success,
    greedy_len, conv_episode, conv_steps, path_len, path)``. The C kernel releases the GIL, as numba's does.
    """
    ck = c_kernels()
    if ck is None:
        from ndrql.planning import kernel  # lazy: loads numba

        return kernel.train(nxt, start, goal, r_c, q, seed, alpha, gamma, eps_thr, max_steps, max_episodes, window,
                            r_collision, r_goal, r_revisit)
    if not (isinstance(q, np.ndarray) and q.dtype == np.float64 and q.flags.c_contiguous and q.flags.writeable):
        raise TypeError("q must be a writeable C-contiguous float64 array (it is updated in place)")
    out = ck.train(np.ascontiguousarray(nxt, dtype=np.int32), int(start), int(goal),
                   np.ascontiguousarray(r_c, dtype=np.float64), q, int(seed), float(alpha), float(gamma),
                   int(eps_thr), int(max_steps), int(max_episodes), int(window), float(r_collision), float(r_goal),
                   float(r_revisit))
    n_done, steps, returns, success, greedy_len, conv_episode, conv_steps, best_len, best = out
    return (n_done, np.frombuffer(steps, dtype=np.int64), np.frombuffer(returns, dtype=np.float64),
            np.frombuffer(success, dtype=np.bool_), np.frombuffer(greedy_len, dtype=np.int64), conv_episode,
            conv_steps, best_len, np.frombuffer(best, dtype=np.int64))


def draws(seed: int, n: int) -> np.ndarray:
    """``n`` raw outputs of Q-learning's generator for ``seed`` (uint64), from the kernel that runs."""
    ck = c_kernels()
    if ck is None:
        from ndrql.planning import kernel  # lazy: loads numba

        return kernel._draws(seed, n)
    return np.frombuffer(ck.draws(int(seed), int(n)), dtype=np.uint64)


def warm_up() -> None:
    """Load (or, on numba's first run, compile) the kernels now, e.g. before forking workers. Nothing to do
    with the C kernels."""
    if c_kernels() is None:
        from ndrql.planning import kernel  # lazy: loads numba

        kernel.warm_up()


def compile_notice() -> str | None:
    """The one line saying that this run compiles the kernels (numba's first run after install), else None.
    Always None with the C kernels: they were compiled when the package was installed."""
    if c_kernels() is not None:
        return None
    from ndrql.planning import kernel  # lazy: loads numba

    return kernel.compile_notice()
