"""The search spaces of ``ndrql tune``: which constants each method's search explores, and where.

One rule for every method, read off the priors it uses (:class:`~ndrql.planning.methods.Method`):

- every method, QL included: alpha, epsilon, gamma (the Q-learning update, Eq. 1);
- a continuous reward (D-CRF Eq. 2 or NDR-CRF Eq. 3): ``r_max``;
- D-CRF (Eq. 2): ``G`` (one decay length for rows and columns, ``g_row = g_col``);
- D-CRF and NDR-CRF together (Eq. 4): ``omega_crf``;
- NDR-QI (Eqs. 6-7): ``omega_qi``, the mask value ``mask_low`` and the threshold's start and step.

D-QI (Eq. 5) has no constant of its own, so O-QL (= D-Q) searches the same three as QL.
:data:`SPACE_VERSION` names this module's ranges in study names, so changing a range starts new
studies instead of mixing trials from two spaces.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import Method, get_method

#: Bump when a range below changes (it is part of every study's name). Version 1 (alpha up to 0.9,
#: epsilon from 0.01, gamma 0.9-0.99, r_max up to 30, G up to 40) put best trials on its edges.
SPACE_VERSION = 2


@dataclass(frozen=True)
class Param:
    """One searched constant: its range and which config field(s) it sets."""

    name: str
    """Name in the study (Optuna's parameter name)."""
    low: float
    """Lower end of the range."""
    high: float
    """Upper end of the range."""
    log: bool
    """Sample on a log scale."""
    part: str
    """``ql`` (:class:`QLConfig`) or ``priors`` (:class:`PriorConfig`)."""
    fields: tuple[str, ...]
    """Config fields set to the sampled value (``G`` sets both ``g_row`` and ``g_col``)."""
    doc: str = ""
    """What it is, with the paper's equation."""


ALPHA = Param("alpha", 0.03, 1.0, True, "ql", ("alpha",), "learning rate (Eq. 1 update)")
EPSILON = Param("epsilon", 0.001, 0.5, True, "ql", ("epsilon",), "exploration rate of epsilon-greedy")
GAMMA = Param("gamma", 0.8, 0.999, False, "ql", ("gamma",), "discount factor")
R_MAX = Param("r_max", 0.5, 200.0, True, "priors", ("r_max",), "maximum continuous reward (Eqs. 2-4)")
G = Param("G", 2.0, 200.0, True, "priors", ("g_row", "g_col"), "D-CRF decay length in cells, G_x = G_y (Eq. 2)")
OMEGA_CRF = Param("omega_crf", 0.0, 1.0, False, "priors", ("omega_crf",), "weight of NDR-CRF against D-CRF (Eq. 4)")
OMEGA_QI = Param("omega_qi", 0.0, 1.0, False, "priors", ("omega_qi",), "weight of the region mask (Eq. 6)")
MASK_LOW = Param("mask_low", -50.0, -0.5, False, "priors", ("mask_low",), "MASK value outside the region (Eq. 7)")
THD_START = Param("thd_start", 0.5, 0.99, False, "priors", ("thd_start",), "first threshold tried (Eq. 7)")
THD_STEP = Param("thd_step", 0.005, 0.1, True, "priors", ("thd_step",), "threshold decrement (Eq. 7)")


#: Prior constants a preset may set that no search explores (beyond the paper: Eq. 6's route ties and distance
#: through the region, Eq. 7's widened region). A search that starts from a preset holds them at its values
#: (:func:`fixed_priors`), so a re-searched preset keeps them.
FIXED_PRIORS = ("region_dilation", "guideline_ties", "region_distance", "thd_tail")


def fixed_priors(priors: PriorConfig) -> tuple[tuple[str, float], ...]:
    """The :data:`FIXED_PRIORS` of ``priors`` that differ from the defaults, as ``(name, value)`` pairs."""
    spec = PriorConfig()
    return tuple((k, float(getattr(priors, k))) for k in FIXED_PRIORS if getattr(priors, k) != getattr(spec, k))


def search_space(method: str | Method) -> tuple[Param, ...]:
    """The constants searched for ``method`` (module docstring), in a fixed order."""
    m = get_method(method)
    space = [ALPHA, EPSILON, GAMMA]
    if m.d_crf or m.n_crf:
        space.append(R_MAX)
    if m.d_crf:
        space.append(G)
    if m.d_crf and m.n_crf:
        space.append(OMEGA_CRF)
    if m.n_qi:
        space += [OMEGA_QI, MASK_LOW, THD_START, THD_STEP]
    return tuple(space)


def configs_from_params(params: dict[str, float], base_ql: QLConfig = QLConfig(),
                        base_priors: PriorConfig = PriorConfig()) -> tuple[QLConfig, PriorConfig]:
    """Configs with the sampled ``params`` (by :attr:`Param.name`) set on ``base_*``."""
    from dataclasses import replace

    by_name = {p.name: p for p in (ALPHA, EPSILON, GAMMA, R_MAX, G, OMEGA_CRF, OMEGA_QI, MASK_LOW, THD_START, THD_STEP)}
    ql: dict[str, float] = {}
    pri: dict[str, float] = {}
    for name, value in params.items():
        p = by_name[name]
        for f in p.fields:
            (ql if p.part == "ql" else pri)[f] = float(value)
    return replace(base_ql, **ql), replace(base_priors, **pri)


def params_of(method: str | Method, ql: QLConfig, priors: PriorConfig) -> dict[str, float]:
    """The searched constants of ``method`` read from configs (the SPEC point: the defaults)."""
    out = {}
    for p in search_space(method):
        cfg = ql if p.part == "ql" else priors
        out[p.name] = float(getattr(cfg, p.fields[0]))
    return out


def distributions(method: str | Method) -> dict[str, Any]:
    """Optuna distributions of ``method``'s space (imports optuna)."""
    from optuna.distributions import FloatDistribution

    return {p.name: FloatDistribution(p.low, p.high, log=p.log) for p in search_space(method)}


def suggest(trial: Any, method: str | Method) -> dict[str, float]:
    """Sample ``method``'s space with an Optuna ``trial``."""
    return {p.name: trial.suggest_float(p.name, p.low, p.high, log=p.log) for p in search_space(method)}


def space_table(methods: tuple[str, ...]) -> list[list[str]]:
    """Rows ``[constant, range, scale, methods that search it, meaning]`` for reports."""
    rows = []
    for p in (ALPHA, EPSILON, GAMMA, R_MAX, G, OMEGA_CRF, OMEGA_QI, MASK_LOW, THD_START, THD_STEP):
        users = [m for m in methods if p in search_space(m)]
        rows.append([p.name, f"{p.low:g} .. {p.high:g}", "log" if p.log else "linear", ", ".join(users) or "-", p.doc])
    return rows
