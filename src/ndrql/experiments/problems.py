"""The fixed maps of Tables 2-3 (``maps_table3.json``); the planning problems themselves are
:class:`ndrql.pipeline.samples.Problem`."""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources


@dataclass(frozen=True)
class MapRef:
    """A dataset sample picked for a table."""

    split: str
    """``seen`` or ``unseen`` (TEST/SEEN, TEST/UNSEEN)."""
    index: int
    """Sample index in the split."""
    label: str = ""
    """Name in the table (``MAP-1``)."""
    reason: str = ""
    """Why this sample (from the versioned list)."""

    @property
    def key(self) -> str:
        return f"{self.split}-{self.index}"


def table3_maps() -> list[MapRef]:
    """The 8 fixed maps of Table 3, from ``maps_table3.json`` (Table 2 uses the first 5)."""
    text = resources.files("ndrql.experiments").joinpath("maps_table3.json").read_text()
    data = json.loads(text)
    return [MapRef(m["split"], int(m["index"]), m["label"], m["reason"]) for m in data["maps"]]
