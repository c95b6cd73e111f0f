"""The sample map bundled with the package (``ndrql/data/sample_map.*``): ``ndrql demo`` and ``--example``."""

from __future__ import annotations

import json
from importlib import resources

from ndrql.maps.problem import GridMapProblem
from ndrql.maps.readers import read_image


def bundled_sample() -> GridMapProblem:
    """Load the bundled 201x201 sample (path-planning dataset, TEST/SEEN 906, GPLv3) with its recorded
    start and goal (``sample_map.json``), as ``(row, col)`` pixels. ``info["source"]`` describes it;
    ``grid_map.source`` is where the map file is installed (``.../ndrql/data/sample_map.png``)."""
    data = resources.files("ndrql") / "data"
    meta = json.loads((data / "sample_map.json").read_text(encoding="utf-8"))
    with resources.as_file(data / meta["map"]) as path:
        grid_map = read_image(path)
    start = (int(meta["start"][0]), int(meta["start"][1]))
    goal = (int(meta["goal"][0]), int(meta["goal"][1]))
    return GridMapProblem.of(grid_map, start, goal, {"source": meta["source"]})
