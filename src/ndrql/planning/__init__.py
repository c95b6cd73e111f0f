"""Tabular Q-learning planners of the paper: rules (Eq. 1), compiled kernel, priors (Eqs. 2-7).

Light on import (names load on first use; numba only when a run starts)::

    from ndrql.planning import run_plan, run_many, PlanJob, QLConfig, PriorConfig, METHODS
"""

from __future__ import annotations

import importlib
from typing import Any

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


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f"ndrql.planning.{_EXPORTS[name]}"), name)  # lazy: names load on use
        globals()[name] = value
        return value
    raise AttributeError(f"module 'ndrql.planning' has no attribute {name!r}")
