"""Frozen configuration of the Q-learning planners, with the defaults of docs/method.md."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, fields

from ndrql.errors import BoundError
from ndrql.limits import check_fields
from ndrql.planning import rules

#: Largest :attr:`QLConfig.max_episodes`: a run's records grow as it goes (25 bytes an episode), so a
#: run that converges early costs nothing for a high cap, and one that never converges stays under 250 MB.
MAX_EPISODES = 10**7
#: Largest :attr:`QLConfig.max_steps` and :attr:`QLConfig.window` (they allocate nothing).
MAX_STEPS = 10**9
#: Largest magnitude of a reward or prior constant: Q-values stay far from overflow (``r / (1 - gamma)``).
MAX_MAGNITUDE = 1e6


def check_numbers(obj: object, names: tuple[str, ...], bound: float = MAX_MAGNITUDE) -> None:
    """``ValueError`` unless each field in ``names`` is a finite number of magnitude at most ``bound``."""
    for name in names:
        v = getattr(obj, name)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or abs(v) > bound:
            raise BoundError(f"{name} must be a finite number in [-{bound:g}, {bound:g}], got {str(v)[:40]}")


def _check_count(value: object, name: str, lo: int = 1, hi: int = MAX_STEPS) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise BoundError(f"{name} must be an integer in {lo}..{hi:,}, got {str(value)[:40]}")


@dataclass(frozen=True)
class QLConfig:
    """Hyper-parameters of tabular Q-learning and of convergence (docs/method.md, sections 2-3)."""

    alpha: float = 0.1
    """Learning rate (paper: fixed 0.1)."""
    epsilon: float = 0.2
    """Exploration rate of epsilon-greedy (paper: fixed 0.2)."""
    gamma: float = 0.95
    """Discount factor (the paper gives none; 0.9 drowns the goal's value 60 moves away)."""
    max_steps: int | None = None
    """Moves per episode before it is cut; ``None`` = 4 x the number of grid cells."""
    max_episodes: int = 20000
    """Episodes before a run stops and is reported as not converged."""
    window: int = 20
    """W: converged once the greedy rollout reaches the goal with the same path W episodes running."""
    reward_collision: float = rules.REWARD_COLLISION
    """Eq. 1 scenario 1: moving into an obstacle or off the map (the agent stays)."""
    reward_goal: float = rules.REWARD_GOAL
    """Eq. 1 scenario 2: reaching the goal (the episode ends)."""
    reward_revisit: float = rules.REWARD_REVISIT
    """Eq. 1 scenario 3: moving into a cell already visited in this episode."""

    def __post_init__(self) -> None:
        check_numbers(self, ("alpha", "epsilon", "gamma", "reward_collision", "reward_goal", "reward_revisit"))
        if not 0.0 < self.alpha <= 1.0:
            raise BoundError(f"alpha must be in (0, 1], got {self.alpha}")
        if not 0.0 <= self.epsilon <= 1.0:
            raise BoundError(f"epsilon must be in [0, 1], got {self.epsilon}")
        if not 0.0 <= self.gamma < 1.0:
            raise BoundError(f"gamma must be in [0, 1), got {self.gamma}")
        if self.max_steps is not None:
            _check_count(self.max_steps, "max_steps")
        _check_count(self.max_episodes, "max_episodes", hi=MAX_EPISODES)
        _check_count(self.window, "window")
        check_fields(self, tuple(f.name for f in fields(self)))  # the one table: ndrql.limits.BOUNDS

    def steps_cap(self, cells: int) -> int:
        """``max_steps`` resolved for a grid of ``cells`` cells (default ``4 * cells``)."""
        return int(self.max_steps) if self.max_steps is not None else 4 * int(cells)


#: Largest :attr:`PriorConfig.region_dilation` (cells): more would turn the region into the whole map.
MAX_DILATION = 10
#: Largest :attr:`PriorConfig.guideline_ties`: with the straight line's share (``priors.TIE_BREAK``) it must
#: stay under one move, so that it orders only moves that are equally far from the goal.
MAX_TIES = 0.95


#: The prior constants beyond the paper that are a switch: name -> (what 0 means, what 1 means).
PRIOR_SWITCHES: dict[str, tuple[str, str]] = {"region_distance": ("the paper", "moves through the region"),
                                              "thd_tail": ("the schedule alone", "on by 0.01 down to 0")}


@dataclass(frozen=True)
class PriorConfig:
    """Parameters of the priors (docs/method.md, paper Eqs. 2-7)."""

    r0: float = 0.0
    """Eq. 2: base reward for a move into free space (plain QL: ``r_c = r0 = 0``)."""
    r_max: float = 5.0
    """Eqs. 2-4: maximum continuous reward, shared by every method (keep r_max / (1 - gamma) <= 100)."""
    g_row: float = 10.0
    """Eq. 2: G_x, decay length of D-CRF along rows (x = row in the dataset), in cells."""
    g_col: float = 10.0
    """Eq. 2: G_y, decay length of D-CRF along columns, in cells."""
    omega_crf: float = 0.5
    """Eq. 4: weight of NDR-CRF against D-CRF."""
    omega_qi: float = 0.5
    """Eq. 6: weight of the region mask against the distance term."""
    mask_low: float = -10.0
    """Eq. 7: MASK value outside the thresholded region (0 inside)."""
    thd_start: float = 0.99
    """Eq. 7: the adaptive threshold starts here ..."""
    thd_step: float = 0.01
    """... and drops by this much until the region connects start and goal."""
    region_dilation: int = 0
    """Eq. 7, beyond the paper: widen the predicted region by this many cells (a 4-connected grey
    dilation) before it is thresholded; 0 = the paper."""
    guideline_ties: float = 0.0
    """Eq. 6 with a predicted distance, beyond the paper: weight (under 1) of the guideline in choosing
    among equally distant moves; 0 = the straight line alone."""
    region_distance: int = 0
    """Eq. 6, beyond the paper: 1 = dist(s', goal) counts the moves to the goal through the region of Eq. 7
    (free cells above its threshold) wherever the region reaches the goal, the given distance or the straight
    line elsewhere; 0 = the given distance or the straight line alone (the paper)."""
    thd_tail: int = 0
    """Eq. 7, beyond the paper: 1 = a schedule that ends above 0 goes on by the paper's step (0.01) down to 0,
    so a coarse ``thd_step`` still tries the low thresholds where a faint region joins start and goal; 0 = the
    schedule alone (the paper's, 0.99 by 0.01, already ends at 0)."""

    def __post_init__(self) -> None:
        check_numbers(self, tuple(f.name for f in fields(self)))
        for name in ("omega_crf", "omega_qi", "thd_start"):
            v = getattr(self, name)
            if not 0.0 <= v <= 1.0:
                raise BoundError(f"{name} must be in [0, 1], got {v}")
        if self.thd_step <= 0:
            raise BoundError(f"thd_step must be > 0, got {self.thd_step}")
        if self.g_row <= 0 or self.g_col <= 0:
            raise BoundError("g_row and g_col must be > 0")
        if not 0 <= self.region_dilation <= MAX_DILATION or int(self.region_dilation) != self.region_dilation:
            raise BoundError(f"region_dilation must be a whole number of cells in [0, {MAX_DILATION}], "
                             f"got {self.region_dilation}")
        object.__setattr__(self, "region_dilation", int(self.region_dilation))  # a preset file's 1.0 is 1 cell
        for name, (off, on) in PRIOR_SWITCHES.items():
            v = getattr(self, name)
            if v not in (0, 1):
                raise BoundError(f"{name} must be 0 ({off}) or 1 ({on}), got {v}")
            object.__setattr__(self, name, int(v))  # a preset file's 1.0 is 1
        if not 0.0 <= self.guideline_ties <= MAX_TIES:
            raise BoundError(f"guideline_ties must be in [0, {MAX_TIES}] (it only breaks ties), got {self.guideline_ties}")
        check_fields(self, tuple(f.name for f in fields(self)))  # the one table: ndrql.limits.BOUNDS


def field_docs(cls) -> dict[str, str]:
    """``{field: one-line doc}`` of a config dataclass, read from the attribute docstrings."""
    import ast

    docs: dict[str, str] = {}
    node = _class_node(cls)
    body = node.body if node is not None else ast.parse(_class_source(cls)).body[0].body  # type: ignore[attr-defined]
    for prev, node in zip(body, body[1:]):
        if isinstance(prev, ast.AnnAssign) and isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant):
            docs[prev.target.id] = str(node.value.value)  # type: ignore[union-attr]
    return {f.name: docs.get(f.name, "") for f in fields(cls)}


def _class_source(cls) -> str:
    import inspect

    return inspect.getsource(cls)


def _class_node(cls):
    """The ``ClassDef`` of ``cls`` in its module's syntax tree (parsed once per module), or ``None`` when it
    cannot be found there (then :func:`field_docs` asks :mod:`inspect`, which tokenises the class: slower)."""
    import sys

    module = sys.modules.get(cls.__module__)
    tree = _module_tree(getattr(module, "__file__", None) or "")
    if tree is None or "<locals>" in cls.__qualname__:
        return None
    node = tree
    for name in cls.__qualname__.split("."):
        found = [n for n in getattr(node, "body", ()) if type(n).__name__ == "ClassDef" and n.name == name]
        if len(found) != 1:
            return None
        node = found[0]
    return node


@functools.lru_cache(maxsize=16)
def _module_tree(filename: str):
    """The syntax tree of the source file ``filename`` (``None`` when it has no readable source)."""
    import ast
    import linecache

    if not filename.endswith(".py"):
        return None
    lines = linecache.getlines(filename)
    return ast.parse("".join(lines)) if lines else None
