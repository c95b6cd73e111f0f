"""Which weights file a name means: the shipped ``paper``, ``general`` and ``belief`` models, or a path.

``paper`` is the model of the paper's setting (trained on the paper's dataset only; it sees the map
resized to 201 px) and keeps the reproduction tables reproducible. ``general`` sees the planning grid
at 4 px per cell and was trained on the paper's data plus generated maps of many families and scales
(``docs/results.md#transfer``); it is the default of ``ndrql plan``, ``demo`` and the API. ``belief`` is
general warm-started with an input channel for cells unknown to the planner (issue 54, ``studies/partial``): when
it is installed, a plan on a map the planner does not fully know (``--hide``, a ROS map's unknown space counted
free) uses it unless weights are named (:func:`plan_weights`); without it such a plan declines the network and
runs IQL-BFS on the belief.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path
from ndrql.errors import NdrqlError
from ndrql.io.readset import note_input

#: Name -> file inside ``ndrql/data``.
SHIPPED_WEIGHTS: dict[str, str] = {"paper": "ndr_default.pt", "general": "ndr_general.pt", "belief": "ndr_belief.pt"}
#: The weights ``plan``, ``demo`` and the API use when none are named (``$NDRQL_WEIGHTS`` overrides).
DEFAULT_WEIGHTS = "general"
#: The weights a plan on a belief map uses when none are named and they are installed (:func:`plan_weights`).
BELIEF_WEIGHTS = "belief"
#: The weights of the paper's tables (``reproduce table1`` ... ``scale``).
PAPER_WEIGHTS = "paper"


def shipped_weights(name: str) -> Path:
    """Path of the shipped weights called ``name`` (:data:`SHIPPED_WEIGHTS`)."""
    return Path(str(resources.files("ndrql") / "data" / SHIPPED_WEIGHTS[name]))


def installed(name: str) -> bool:
    """Whether the shipped weights ``name`` are installed (``belief`` ships once trained)."""
    return shipped_weights(name).is_file()


def plan_weights(spec: str | os.PathLike | None, partial: bool) -> str | os.PathLike | None:
    """The weights a plan asks for: ``spec`` as given; with none named (neither ``spec`` nor ``$NDRQL_WEIGHTS``) on a
    map the planner does not fully know (``partial``), the shipped ``belief`` weights when they are installed."""
    if spec is None and partial and not os.environ.get("NDRQL_WEIGHTS") and installed(BELIEF_WEIGHTS):
        return BELIEF_WEIGHTS
    return spec


def resolve_weights(spec: str | os.PathLike | None = None, default: str = DEFAULT_WEIGHTS) -> Path:
    """The weights file ``spec`` names: ``paper``, ``general`` or a path; ``None`` means
    ``$NDRQL_WEIGHTS`` (itself a name or a path) when set, else the shipped ``default``."""
    if spec is None:
        spec = os.environ.get("NDRQL_WEIGHTS") or default
    text = os.fspath(spec)
    path = shipped_weights(text) if text in SHIPPED_WEIGHTS else Path(text)
    if text in SHIPPED_WEIGHTS and not path.is_file():
        raise NdrqlError(f"the {text!r} weights are not installed with this package (ndrql/data/{path.name}); "
                         f"give other weights (--weights general) or a checkpoint file")
    note_input(path, "the weights")
    return path


def weights_label(path: str | os.PathLike) -> str:
    """``paper``/``general``/``belief`` for the shipped files, else the path as given."""
    p = Path(path)
    for name in SHIPPED_WEIGHTS:
        try:
            if p.resolve() == shipped_weights(name).resolve():
                return name
        except OSError:
            pass
    return str(path)
