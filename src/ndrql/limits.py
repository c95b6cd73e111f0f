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

__all__ = ["DEVELOPMENT_SEEDS", "MIN_GRID_SIZE", "MAX_GRID_SIZE", "MAX_RUNS", "MAX_THREADS", "MAX_WORKERS", "SEALED_SEEDS",
           "SEED_LIMIT", "TRAINING_SEEDS", "available_cores", "check_cell", "check_finite", "check_int", "check_seeds",
           "check_threads", "check_training_seed", "seed_role"]

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
MIN_GRID_SIZE = 2
"""Smallest planning grid (cells on a side) any command takes: one cell has nothing to plan."""
MAX_GRID_SIZE = 1024
"""Largest planning grid (cells on a side) any command takes (``plan``'s default ``--max-size`` is smaller).
Checked for every command by :class:`ndrql.pipeline.settings.PlanSettings`."""

#: Seeds of generated maps, by what the maps are for (the one home of these ranges). A set of generated
#: maps takes one seed; sample ``i`` depends only on ``(seed, i)``, so sets with seeds in different
#: ranges never share a draw.
TRAINING_SEEDS = range(0, 900_000)
"""Training sets and any other data a model or a preset learns from (``ndrql data generate``, ``ndrql train``)."""
DEVELOPMENT_SEEDS = range(900_000, 950_000)
"""Development evaluation sets (``transfer``, ``select``, ``tune``, ...): used to choose, so never the release's evidence."""
SEALED_SEEDS = range(950_000, 1_000_000)
"""Sealed evaluation sets: evaluated only by ``ndrql reproduce release``, which counts every run in its ledger."""


def seed_role(seed: int) -> str:
    """What generated maps of ``seed`` are for: ``training``, ``development``, ``sealed`` or ``unassigned``
    (1,000,000 and above: no set of the project uses them)."""
    for name, seeds in (("training", TRAINING_SEEDS), ("development", DEVELOPMENT_SEEDS), ("sealed", SEALED_SEEDS)):
        if seed in seeds:
            return name
    return "unassigned"


def check_training_seed(seed: object, name: str = "--seed") -> int:
    """``seed`` if it is a training seed (:data:`TRAINING_SEEDS`), else ``ValueError`` naming the evaluation
    range it falls in: maps drawn from an evaluation seed would be trained on and then evaluated."""
    check_int(seed, name, 0, SEED_LIMIT - 1)
    if seed not in TRAINING_SEEDS:
        role = seed_role(seed)  # type: ignore[arg-type]
        why = f"{role} evaluation sets use it" if role != "unassigned" else "seeds from 1,000,000 up are unassigned"
        raise ValueError(f"{name} {seed} is not a training seed (0..{TRAINING_SEEDS.stop - 1:,}): {why}")
    return seed  # type: ignore[return-value]


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
