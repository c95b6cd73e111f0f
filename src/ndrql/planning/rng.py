"""The kernel's random number generator, in plain Python (for the reference and the tests).

Q-learning draws from its own generator so that a run depends only on its seed, never on numba's
or numpy's global state or on how runs are spread over processes: xoshiro256** (Blackman and
Vigna) seeded by splitmix64. The compiled twin lives in :mod:`ndrql.planning.kernel`; a test
checks both give the same stream.

How one draw ``u`` (64 bits) is used per training step:

- the high 32 bits decide exploration: explore when ``u >> 32 < eps_threshold(epsilon)``;
- the low 32 bits pick among ``k`` actions (a random action, or one of ``k`` tied best actions)
  by Lemire's multiply-shift: ``((u & 0xFFFFFFFF) * k) >> 32``.
"""

from __future__ import annotations

MASK64 = (1 << 64) - 1


def splitmix64(x: int) -> tuple[int, int]:
    """One splitmix64 step: returns ``(new_state, output)``."""
    x = (x + 0x9E3779B97F4A7C15) & MASK64
    z = x
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK64
    return x, z ^ (z >> 31)


def seed_state(seed: int) -> list[int]:
    """The four 64-bit words of xoshiro256** state for ``seed`` (any int, taken modulo 2**64)."""
    x = int(seed) & MASK64
    state = []
    for _ in range(4):
        x, z = splitmix64(x)
        state.append(z)
    return state


def _rotl(x: int, k: int) -> int:
    return ((x << k) | (x >> (64 - k))) & MASK64


def next_u64(state: list[int]) -> int:
    """Advance ``state`` in place and return the next 64-bit output of xoshiro256**."""
    s0, s1, s2, s3 = state
    result = (_rotl((s1 * 5) & MASK64, 7) * 9) & MASK64
    t = (s1 << 17) & MASK64
    s2 ^= s0
    s3 ^= s1
    s1 ^= s2
    s0 ^= s3
    s2 ^= t
    s3 = _rotl(s3, 45)
    state[0], state[1], state[2], state[3] = s0, s1, s2, s3
    return result


def eps_threshold(epsilon: float) -> int:
    """Integer threshold for the high 32 bits: ``P(u >> 32 < thr) = epsilon`` (to 2**-32)."""
    if not 0.0 <= epsilon <= 1.0:
        raise ValueError(f"epsilon must be in [0, 1], got {epsilon}")
    return min(int(round(epsilon * 4294967296.0)), 4294967296)


def pick(u: int, k: int) -> int:
    """Index in ``0..k-1`` from the low 32 bits of ``u`` (Lemire's multiply-shift)."""
    return ((u & 0xFFFFFFFF) * k) >> 32
