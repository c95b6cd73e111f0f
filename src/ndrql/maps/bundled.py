"""The sample map bundled with the package (``ndrql/data/sample_map.*``): ``ndrql demo`` and ``--example``."""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources

from ndrql.maps.grid import Cell, GridMap
from ndrql.maps.readers import read_image


@dataclass(frozen=True)
class BundledSample:
    """A map with its start and goal, as ``(row, col)`` pixels."""

    grid_map: GridMap
    start: Cell
    goal: Cell
    description: str
    path: str = ""
    """Where the map file is installed (``.../ndrql/data/sample_map.png``)."""


def bundled_sample() -> BundledSample:
    """Load the bundled 201x201 sample (path-planning dataset, TEST/SEEN 906, GPLv3) with its recorded
    start and goal (``sample_map.json``)."""
    data = resources.files("ndrql") / "data"
    meta = json.loads((data / "sample_map.json").read_text(encoding="utf-8"))
    with resources.as_file(data / meta["map"]) as path:
        grid_map = read_image(path)
        where = str(path)
    return BundledSample(
        grid_map=grid_map,
        start=(int(meta["start"][0]), int(meta["start"][1])),
        goal=(int(meta["goal"][0]), int(meta["goal"][1])),
        description=meta["source"],
        path=where,
    )
