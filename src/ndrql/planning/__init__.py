"""Tabular Q-learning planners of the paper: rules (Eq. 1), compiled kernel, priors (Eqs. 2-7).

Light on import: the numba kernel loads on first use. The main entry points::

    from ndrql.planning import plan, run_many, PlanJob, QLConfig, PriorConfig, METHODS
"""

from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import METHODS, Method, Priors, build_priors, get_method, predict_priors
from ndrql.planning.results import EpisodeRecords, PlanResult
from ndrql.planning.runner import PlanJob, plan, run_many

__all__ = [
    "METHODS",
    "EpisodeRecords",
    "Method",
    "PlanJob",
    "PlanResult",
    "PriorConfig",
    "Priors",
    "QLConfig",
    "build_priors",
    "get_method",
    "plan",
    "predict_priors",
    "run_many",
]
