"""Bounds on numbers a user gives (flags, API arguments), checked once at the boundary.

Each check raises ``ValueError`` with one line naming the flag and the allowed range; the CLI prints
it as ``ndrql: error: ...`` with exit code 2. The bounds keep memory and time in proportion to what
was asked for: no billion-element seed list, no 20,000 x 20,000 planning grid, no 10^5 processes.

Layering: standard library and :mod:`ndrql.errors` only; any layer may use it.
"""

from __future__ import annotations

import math
import numbers

from ndrql.errors import brief

__all__ = ["MAX_GRID_SIZE", "MAX_RUNS", "MAX_THREADS", "MAX_WORKERS", "SEED_LIMIT", "available_cores", "check_cell",
           "check_finite", "check_int", "check_seeds", "check_threads"]

SEED_LIMIT = 2**63
"""Seeds are ``0 <= seed < 2**63``: numpy, torch and the planning kernel all take them as 64-bit integers."""
MAX_RUNS = 10_000
"""Most seeds in one command (runs per method)."""
MAX_WORKERS = 256
"""Most worker processes in one pool."""
def available_cores() -> int:
    """CPU cores this process may run on (its affinity where the system tells it, else the core count)."""
    import os

    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


MAX_THREADS = available_cores()
"""Most threads for a forward pass or training: the cores this process may use (more only slow it
down, and tens of thousands crash the thread pools of torch and ONNX Runtime)."""
MAX_GRID_SIZE = 1024
"""Largest planning grid for A* and ``map info`` (cells on a side; Q-learning has its own, smaller limit)."""


def check_int(value: object, name: str, lo: int, hi: int | None = None) -> int:
    """``value`` if it is an integer in ``lo..hi`` (``hi=None``: no upper bound), else ``ValueError``."""
    ok = isinstance(value, int) and not isinstance(value, bool)
    if ok and value >= lo and (hi is None or value <= hi):
        return value  # type: ignore[return-value]
    rule = f">= {lo}" if hi is None else f"in {lo}..{hi:,}"
    raise ValueError(f"{name} must be an integer {rule}, got {brief(value)}")


def check_finite(value: object, name: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    """``value`` as a float if it is a finite number in ``[lo, hi]``, else ``ValueError``."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    if ok and math.isfinite(value) and lo <= value <= hi:  # type: ignore[operator]
        return float(value)  # type: ignore[arg-type]
    where = "" if (lo, hi) == (-math.inf, math.inf) else f" in [{lo:g}, {hi:g}]"
    raise ValueError(f"{name} must be a finite number{where}, got {brief(value)}")


def check_threads(value: object, name: str = "threads", lo: int = 1) -> int:
    """``value`` if it is a thread count in ``lo..MAX_THREADS`` (the cores; ``lo=0`` allows "as is")."""
    ok = isinstance(value, int) and not isinstance(value, bool)
    if ok and lo <= value <= MAX_THREADS:  # type: ignore[operator]
        return value  # type: ignore[return-value]
    raise ValueError(f"{name} must be an integer in {lo}..{MAX_THREADS} (the CPU cores this process may use), "
                     f"got {brief(value)}")


def check_cell(point: object, name: str) -> tuple[int, int]:
    """``(row, col)`` as two ints: integers (numpy's too) or whole floats; ``ValueError`` for anything else
    (``(0.7, 0)`` is not truncated to row 0, a bool is not a number, a third coordinate is refused)."""
    try:
        parts = tuple(point)  # type: ignore[arg-type]
    except TypeError:
        parts = ()
    out = []
    for v in parts:
        if isinstance(v, bool) or not isinstance(v, numbers.Real):
            break
        if isinstance(v, numbers.Integral):
            out.append(int(v))
        elif math.isfinite(float(v)) and float(v).is_integer():
            out.append(int(float(v)))
        else:
            break
    if len(parts) != 2 or len(out) != 2:
        raise ValueError(f"{name} must be (row, col), two integers, got {brief(point) if len(parts) != 2 else parts}")
    return out[0], out[1]


def check_seeds(first: object, count: object, first_name: str = "--seed", count_name: str = "--seeds") -> range:
    """The seeds ``first .. first + count - 1`` as a ``range`` (never a list): ``1 <= count <= MAX_RUNS``,
    every seed in ``0 .. 2**63 - 1``."""
    count = check_int(count, count_name, 1, MAX_RUNS)
    if not (isinstance(first, int) and not isinstance(first, bool) and 0 <= first <= SEED_LIMIT - count):
        last = f"2**63 - {count}" if count > 1 else "2**63 - 1"
        raise ValueError(f"{first_name} must be an integer in 0..{last} (every seed below 2**63), got {brief(first)}")
    return range(first, first + count)
