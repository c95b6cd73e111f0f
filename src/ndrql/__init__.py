"""ndrql: learning-guided grid path planning (NDR-QL).

Kept light on purpose: importing ``ndrql`` must not import torch or numba, so the CLI starts fast.
The API loads on first use::

    import ndrql
    result = ndrql.plan("map.png", start=(25, 179), goal=(167, 5))   # -> PlanResult (NDR-QL, seed 0)
"""

from __future__ import annotations

import importlib
from typing import Any

from ndrql.version import __version__

#: Names served lazily from ``ndrql.api`` (importing them pulls numpy and the planners, not torch).
_API = ("plan", "solve", "astar", "AStarRun", "build_request", "PlanRequest", "PlanReport", "PlanSettings",
        "FallbackWarning", "NdrqlWarning")

__all__ = ["__version__", *_API]


def __getattr__(name: str) -> Any:
    if name in _API:
        value = getattr(importlib.import_module("ndrql.api"), name)  # lazy: `import ndrql` stays light
        globals()[name] = value
        return value
    raise AttributeError(f"module 'ndrql' has no attribute {name!r}")
