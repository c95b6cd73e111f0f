"""Q-learning's random number generator, defined once: xoshiro256** (Blackman and Vigna) seeded by splitmix64.

Q-learning draws from its own generator so that a run depends only on its seed, never on numba's
or numpy's global state or on how runs are spread over processes. :func:`state_from_seed`
and :func:`xoshiro` are written on ``numpy.uint64`` values in the subset of Python that numba
compiles: the compiled kernel (:mod:`ndrql.planning.kernel`) compiles these very functions, and the
numpy reference (:mod:`ndrql.planning.reference`) calls them as they are, through :func:`seed_state`
and :func:`next_u64` (which silence numpy's warning when ``uint64`` arithmetic wraps around: the
generator wants the wrap).

How one draw ``u`` (64 bits) is used per training step:

- the high 32 bits decide exploration: explore when ``u >> 32 < eps_threshold(epsilon)``;
- the low 32 bits pick among ``k`` actions (a random action, or one of ``k`` tied best actions)
  by Lemire's multiply-shift: ``((u & 0xFFFFFFFF) * k) >> 32``.
"""

from __future__ import annotations

import numpy as np


def state_from_seed(seed):
    """The four 64-bit words of xoshiro256** state for ``seed`` (0..2**63-1), by splitmix64 (numba subset)."""
    st = np.empty(4, dtype=np.uint64)
    x = np.uint64(seed)
    for i in range(4):
        x = x + np.uint64(0x9E3779B97F4A7C15)
        z = x
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        st[i] = z ^ (z >> np.uint64(31))
    return st


def xoshiro(s0, s1, s2, s3):
    """One step of xoshiro256** on a state held in four ``uint64`` values: returns ``(output, s0, s1, s2, s3)``
    (numba subset).

    The kernel keeps the state in local variables (one draw per training step); ``rotl(x, k)`` is
    written out as ``(x << k) | (x >> (64 - k))``.
    """
    x = s1 * np.uint64(5)
    result = ((x << np.uint64(7)) | (x >> np.uint64(57))) * np.uint64(9)
    t = s1 << np.uint64(17)
    s2 ^= s0
    s3 ^= s1
    s1 ^= s2
    s0 ^= s3
    s2 ^= t
    s3 = (s3 << np.uint64(45)) | (s3 >> np.uint64(19))
    return result, s0, s1, s2, s3


def seed_state(seed: int) -> np.ndarray:
    """:func:`state_from_seed` in plain Python (the reference's and the tests' generator)."""
    with np.errstate(over="ignore"):
        return state_from_seed(seed)


def next_u64(state: np.ndarray) -> int:
    """Advance ``state`` (from :func:`seed_state`) in place and return its next 64-bit output, in plain Python."""
    with np.errstate(over="ignore"):
        result, state[0], state[1], state[2], state[3] = xoshiro(state[0], state[1], state[2], state[3])
    return int(result)


def eps_threshold(epsilon: float) -> int:
    """Integer threshold for the high 32 bits: ``P(u >> 32 < thr) = epsilon`` (to 2**-32)."""
    if not 0.0 <= epsilon <= 1.0:
        raise ValueError(f"epsilon must be in [0, 1], got {epsilon}")
    return min(int(round(epsilon * 4294967296.0)), 4294967296)


def pick(u: int, k: int) -> int:
    """Index in ``0..k-1`` from the low 32 bits of ``u`` (Lemire's multiply-shift)."""
    return ((u & 0xFFFFFFFF) * k) >> 32
