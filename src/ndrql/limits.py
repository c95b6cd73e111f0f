"""Bounds on numbers a user gives (flags, API arguments, environment variables), checked once at the boundary.

:data:`BOUNDS` is the one table: the range of every numeric flag and config field, and why (what a value
beyond it costs); :data:`ENV_VARS` lists the environment variables. The CLI checks every parsed flag against
it before the command runs (:func:`ndrql.cli.options.check_flags`), the config classes their fields
(:func:`check_fields`), and a test fails for a numeric flag, field or variable the table lacks.

Each check raises :class:`~ndrql.errors.BoundError` (an ``NdrqlError`` and a ``ValueError``) with one line
naming the flag and the allowed range; the CLI prints it as ``ndrql: error: ...`` with exit code 2. The bounds keep memory and time in proportion to what
was asked for: no billion-element seed list, no 20,000 x 20,000 planning grid, no 10^5 processes.

Layering: standard library and :mod:`ndrql.errors` only; any layer may use it.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from ndrql.errors import BoundError, brief

__all__ = ["BOUNDS", "ENV_VARS", "Bound", "bound_for", "check_bound", "check_fields", "env_number", "field_key",
           "DEVELOPMENT_SEEDS", "MIN_GRID_SIZE", "MAX_GRID_SIZE", "MAX_RUNS", "MAX_THREADS", "MAX_WORKERS", "SEALED_SEEDS",
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
        raise BoundError(f"{name} {seed} is not a training seed (0..{TRAINING_SEEDS.stop - 1:,}): {why}")
    return seed  # type: ignore[return-value]


def check_int(value: object, name: str, lo: int, hi: int | None = None) -> int:
    """``value`` if it is an integer in ``lo..hi`` (``hi=None``: no upper bound), else ``ValueError``."""
    ok = isinstance(value, int) and not isinstance(value, bool)
    if ok and value >= lo and (hi is None or value <= hi):
        return value  # type: ignore[return-value]
    rule = f">= {lo}" if hi is None else f"in {lo}..{hi:,}"
    raise BoundError(f"{name} must be an integer {rule}, got {brief(value)}")


def check_finite(value: object, name: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    """``value`` as a float if it is a finite number in ``[lo, hi]``, else ``ValueError``."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    if ok and math.isfinite(value) and lo <= value <= hi:  # type: ignore[operator]
        return float(value)  # type: ignore[arg-type]
    where = "" if (lo, hi) == (-math.inf, math.inf) else f" in [{lo:g}, {hi:g}]"
    raise BoundError(f"{name} must be a finite number{where}, got {brief(value)}")


def check_threads(value: object, name: str = "threads", lo: int = 1) -> int:
    """``value`` if it is a thread count in ``lo..MAX_THREADS`` (the cores; ``lo=0`` allows "as is")."""
    ok = isinstance(value, int) and not isinstance(value, bool)
    if ok and lo <= value <= MAX_THREADS:  # type: ignore[operator]
        return value  # type: ignore[return-value]
    raise BoundError(f"{name} must be an integer in {lo}..{MAX_THREADS} (the CPU cores this process may use), "
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
        raise BoundError(f"{name} must be (row, col), two integers, got {brief(point) if len(parts) != 2 else parts}")
    return out[0], out[1]


def check_seeds(first: object, count: object, first_name: str = "--seed", count_name: str = "--seeds") -> range:
    """The seeds ``first .. first + count - 1`` as a ``range`` (never a list): ``1 <= count <= MAX_RUNS``,
    every seed in ``0 .. 2**63 - 1``."""
    count = check_int(count, count_name, 1, MAX_RUNS)
    if not (isinstance(first, int) and not isinstance(first, bool) and 0 <= first <= SEED_LIMIT - count):
        last = f"2**63 - {count}" if count > 1 else "2**63 - 1"
        raise BoundError(f"{first_name} must be an integer in 0..{last} (every seed below 2**63), got {brief(first)}")
    return range(first, first + count)


# --- the one table of bounds: every numeric flag, config field and environment variable -------------------

@dataclass(frozen=True)
class Bound:
    """The range a number may take and why (what a value beyond it would cost)."""

    lo: float
    hi: float
    why: str
    integer: bool = True
    off: float | None = None
    """A value outside ``lo..hi`` that means "off" or "default" (``0`` threads: all cores)."""
    note: str = ""
    """Said in the message after the range (where the range depends on the machine)."""

    def rule(self) -> str:
        hi = "2**63 - 1" if self.hi == SEED_LIMIT - 1 else f"{int(self.hi):,}"
        span = f"an integer in {int(self.lo)}..{hi}" if self.integer else f"a finite number in [{self.lo:g}, {self.hi:g}]"
        return span + ("" if self.off is None else f" (or {self.off:g})") + (f" ({self.note})" if self.note else "")


def _workers_cap() -> int:
    return max(4, available_cores())


_SEED = Bound(0, SEED_LIMIT - 1, "numpy, torch and the kernel take 64-bit seeds")
_CELLS = Bound(MIN_GRID_SIZE, MAX_GRID_SIZE, "cells on a side: memory and Q-learning's episode cap grow with the cells")
_UNIT = Bound(0, 1, "a weight or a probability", integer=False)
_REWARD = Bound(-1000, 1000, "rewards beyond this only rescale the Q-table", integer=False)
_SWITCH = Bound(0, 1, "a switch: 0 off, 1 on")
_CORES_NOTE = "the CPU cores this process may use"
_CORES = Bound(1, MAX_THREADS, "more threads than cores only slow a run down", note=_CORES_NOTE)

#: Every numeric command-line flag (key ``--flag``, or ``COMMAND --flag`` where a command differs) and config field
#: (key ``Class.field``). :func:`check_flags` checks the flags where the arguments are parsed, the config classes
#: check their fields in ``__post_init__`` (the API's requests), :data:`ENV_VARS` lists the environment.
BOUNDS: dict[str, Bound] = {
    "--seed": _SEED, "--order-seed": _SEED, "--mask-seed": _SEED,
    "--seeds": Bound(1, MAX_RUNS, "runs per method; each is a Q-learning run"),
    "--workers": Bound(1, _workers_cap(), "processes beyond the cores only cost memory (each loads the planners)"),
    "--threads": _CORES, "train --threads": Bound(1, MAX_THREADS, "more threads than cores only slow a run down", off=0, note=_CORES_NOTE),
    "eval --threads": Bound(1, MAX_THREADS, "more threads than cores only slow a run down", off=0, note=_CORES_NOTE),
    "--dpi": Bound(30, 600, "figure pixels grow with the square of the resolution"),
    "--threshold": Bound(0, 256, "a gray value of an 8-bit image", integer=False),
    "--max-pixels": Bound(1, 2**25, "a map's arrays take about 40 bytes a pixel: 2**25 pixels is 1.3 GB"),
    "--robot-radius": Bound(0, 10_000, "metres or pixels; larger inflates every map to one obstacle", integer=False),
    "--path-spacing": Bound(0.001, 10_000, "poses per path grow as its inverse", integer=False, off=0),
    "--size": _CELLS, "export-onnx --size": Bound(32, 4096, "the traced input side in pixels"),
    "data generate --size": Bound(16, 4096, "a generated map's side in pixels"),
    "--max-size": _CELLS, "--grid": _CELLS,
    "--sense": Bound(0, MAX_GRID_SIZE, "cells seen around the agent", integer=False),
    "--sense-every": Bound(1, 10_000, "episodes between rebuilds of the priors"),
    "--alpha": Bound(1e-6, 1, "a smaller rate never converges within the episode cap", integer=False),
    "--epsilon": _UNIT, "--gamma": Bound(0, 0.9999, "values grow as 1 / (1 - gamma)", integer=False),
    "--max-steps": Bound(1, 4 * MAX_GRID_SIZE**2, "moves per episode: 4 x the cells of the largest grid"),
    "train --max-steps": Bound(1, 10**9, "optimisation steps", off=0),
    "--max-episodes": Bound(1, 10**7, "episodes of one run; time grows with them"),
    "tune --max-episodes": Bound(1, 1_000_000, "episodes of one run during a search"),
    "--window": Bound(1, 10**9, "episodes the greedy path must repeat; it allocates nothing (--max-episodes bounds the run)"),
    "--reward-collision": _REWARD, "--reward-goal": _REWARD, "--reward-revisit": _REWARD,
    "--r0": Bound(-100, 100, "the base reward of a move", integer=False),
    "--r-max": Bound(0, 1000, "the largest continuous reward (the search goes to 200)", integer=False),
    "--g-row": Bound(0.01, 10_000, "a decay length in cells", integer=False),
    "--g-col": Bound(0.01, 10_000, "a decay length in cells", integer=False),
    "--omega-crf": _UNIT, "--omega-qi": _UNIT, "--thd-start": _UNIT,
    "--mask-low": Bound(-1000, 0, "the mask's value outside the region", integer=False),
    "--thd-step": Bound(0.001, 1, "the schedule holds start / step thresholds, each a connectivity test",
                        integer=False),
    "--region-dilation": Bound(0, 10, "more turns the region into the whole map"),
    "--guideline-ties": Bound(0, 0.95, "it only breaks ties", integer=False),
    "--region-distance": _SWITCH, "--thd-tail": _SWITCH,
    "--count": Bound(1, 1_000_000, "samples written, each a few kilobytes"),
    "data show --count": Bound(1, 256, "samples drawn on one sheet"),
    "--epochs": Bound(1, 10_000, "passes over the data"),
    "--batch-size": Bound(1, 4096, "samples in memory at once"), "train --batch-size": Bound(1, 1024, "samples per step"),
    "--lr": Bound(1e-8, 10, "a larger rate diverges", integer=False),
    "--weight-decay": Bound(0, 10, "a larger decay erases the weights", integer=False),
    "train --unknown-weight": Bound(0, 100, "a larger weight drowns the known pixels in the loss", integer=False),
    "--warmup-steps": Bound(0, 10**7, "optimisation steps"),
    "--val-fraction": Bound(0.001, 0.5, "more leaves too little to train on", integer=False),
    "--loader-workers": Bound(0, 64, "processes building batches"),
    "--checkpoint-minutes": Bound(0.1, 10_000, "minutes between checkpoints", integer=False),
    "--steps-per-epoch": Bound(1, 10**7, "optimisation steps per epoch", off=0),
    "--val-per-source": Bound(1, 100_000, "validation samples per source"),
    "--limit": Bound(1, 1_000_000, "samples evaluated"), "eval --limit": Bound(1, 1_000_000, "samples evaluated", off=0),
    "--per-category": Bound(1, 10_000, "samples per category and split"),
    "--per-family": Bound(1, 1_000_000, "maps per family"),
    "--trials": Bound(1, 100_000, "trials of the search"), "--samples": Bound(1, 12_000, "validation maps"),
    "--chunk": Bound(1, 12_000, "maps between pruning checks"), "--candidates": Bound(1, 1000, "trials checked"),
    "--symmetries": Bound(1, 8, "orientations: one forward pass each"),
    "QLConfig.max_steps": Bound(1, 4 * MAX_GRID_SIZE**2, "moves per episode: 4 x the cells of the largest grid"),
    "PlanSettings.max_map_pixels": Bound(1, 2**25, "a map's arrays take about 40 bytes a pixel: 2**25 pixels is 1.3 GB"),
    "PlanSettings.tolerance": Bound(0, 10, "a route that much longer is no route", integer=False),
    "PlanSettings.predict_budget": Bound(0.001, 3600, "seconds the model may take", integer=False),
    "--predict-budget": Bound(0.001, 3600, "seconds the prediction may take once the model is loaded (or none)", integer=False),
}

#: Environment variables ndrql reads: name -> what it takes (a :class:`Bound` for numbers).
ENV_VARS: dict[str, Bound | str] = {
    "NDRQL_CACHE": "a folder for ndrql's caches", "NDRQL_DATASET": "the dataset folder",
    "NDRQL_WEIGHTS": "paper, general or a weights file", "NDRQL_RGP_WEIGHTS": "an RGP weights file",
    "NDRQL_KERNELS": "auto, c or numba", "NDRQL_DEBUG": "any value: show tracebacks",
    "NDRQL_WRITE_PACKAGE": "1: the maintainers' tools may write the package's files",
    "NDRQL_EVAL_THREADS": Bound(1, MAX_THREADS, "more threads than cores only slow a run down"),
}


def bound_for(key: str, command: str = "") -> Bound | None:
    """The bound of ``key`` (``--flag`` or ``Class.field``), the command's own first (``train --threads``)."""
    return BOUNDS.get(f"{command} {key}".strip()) or BOUNDS.get(key)


def field_key(cls_name: str, field: str) -> str:
    """The table's key for a config field: ``Class.field`` when it has its own row, else the flag ``--field``."""
    own = f"{cls_name}.{field}"
    return own if own in BOUNDS else "--" + field.replace("_", "-")


def check_bound(value: object, bound: Bound, name: str) -> float:
    """``value`` if it lies in ``bound`` (or is its ``off`` value), else ``ValueError`` naming ``name`` and the range."""
    number = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if number and bound.off is not None and value == bound.off:
        return value  # type: ignore[return-value]
    if number and (not bound.integer or float(value).is_integer()) and bound.lo <= value <= bound.hi:  # type: ignore[operator]
        return value  # type: ignore[return-value]
    raise BoundError(f"{name} must be {bound.rule()}, got {brief(value)}")


def check_fields(obj: object, names: tuple[str, ...], *, strict: bool = False) -> None:
    """Check the numeric fields ``names`` of a config dataclass against :data:`BOUNDS` (``None`` = unset; text is
    left to the class unless ``strict``, which refuses anything but a number)."""
    cls = type(obj).__name__
    for name in names:
        value = getattr(obj, name)
        bound = BOUNDS.get(field_key(cls, name))
        if value is not None and bound is not None and (strict or not isinstance(value, str)):
            check_bound(value, bound, name)


def env_number(name: str, default: int) -> int:
    """The integer environment variable ``name`` (:data:`ENV_VARS`), ``default`` when unset; a bad value is a
    ``ValueError`` that names the variable."""
    import os

    text = os.environ.get(name, "").strip()
    if not text:
        return default
    bound = ENV_VARS[name]
    assert isinstance(bound, Bound)
    try:
        value: object = int(text)
    except ValueError:
        value = text
    return int(check_bound(value, bound, f"the environment variable {name}"))


#: Most episodes ``--records`` keeps in one command, over all runs: each is about 500 bytes by the time it is JSON
#: (2 million episodes took 1 GB), so this keeps a run with records near 500 MB.
MAX_RECORDED_EPISODES = 1_000_000


def check_records(runs: int, episodes: int) -> None:
    """``--records`` keeps every episode of every run: ``BoundError`` when ``runs x episodes`` could exceed
    :data:`MAX_RECORDED_EPISODES`."""
    if runs * episodes > MAX_RECORDED_EPISODES:
        raise BoundError(f"--records keeps every episode: {runs:,} run(s) x {episodes:,} episodes is more than "
                         f"{MAX_RECORDED_EPISODES:,} (about 500 MB); lower --max-episodes or --seeds, or drop --records")
