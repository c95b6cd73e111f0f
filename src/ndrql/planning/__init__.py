"""Tabular Q-learning planners of the paper: rules (Eq. 1), compiled kernel, priors (Eqs. 2-7).

Light on import (names load on first use; numba only when a run starts)::

    from ndrql.planning import run_plan, run_many, PlanJob, QLConfig, PriorConfig, METHODS
"""

from __future__ import annotations

from ndrql._lazy import lazy_getattr

_EXPORTS = {
    "QLConfig": "config",
    "PriorConfig": "config",
    "METHODS": "methods",
    "Method": "methods",
    "Priors": "methods",
    "build_priors": "methods",
    "get_method": "methods",
    "EpisodeRecords": "results",
    "PlanResult": "results",
    "PlanJob": "runner",
    "run_plan": "runner",
    "run_many": "runner",
}

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_getattr("ndrql.planning", _EXPORTS, globals())
