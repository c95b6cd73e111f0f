"""The paper's reported numbers (its Tables 1-4), read from ``paper_numbers.json`` beside this module.

The numbers are data, quoted as printed, for the reference columns of the reproduced tables. Schema
of the file (a JSON object; each table an object):

- ``table1``: ``columns`` (``seen R``, ``seen G``, ``unseen R``, ``unseen G``: F1 in percent) and
  ``rows``: model name -> one value per column, ``null`` where the paper reports none;
- ``table2``: ``maps`` (``MAP-1`` .. ``MAP-5``) and ``steps``: row name -> convergence steps per map;
- ``table3``: ``maps`` (``MAP-1`` .. ``MAP-8``), ``steps``: method -> convergence steps per map (one
  run each), ``paths``: method -> ``"shortest/longest"`` training path per map, and
  ``improvement``: method -> the improvement over QL the paper states (a fraction);
- ``table4``: ``columns`` as Table 1 and ``rows``: variant name -> one value per column.

Rows keep the paper's order (JSON objects are read in order).
"""

from __future__ import annotations

import json
from importlib import resources
from typing import Any

TABLES = ("table1", "table2", "table3", "table4")


def paper_table(name: str) -> dict[str, Any]:
    """The paper's ``name`` (``table1`` .. ``table4``) as a fresh dict (module docstring for its keys)."""
    if name not in TABLES:
        raise KeyError(f"no paper numbers for {name!r}; valid: {', '.join(TABLES)}")
    data = json.loads(resources.files("ndrql.experiments").joinpath("paper_numbers.json").read_text())
    return data[name]
