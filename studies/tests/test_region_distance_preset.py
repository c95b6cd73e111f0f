"""studies/large_view/region_distance_preset.py: the candidate preset differs from the shipped one only in
NDR-QL's region_distance on the grids asked for."""

from __future__ import annotations

import dataclasses
import importlib.util
from pathlib import Path

import pytest

from ndrql.planning.preset import load_preset

SCRIPT = Path(__file__).resolve().parents[1] / "large_view" / "region_distance_preset.py"


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("region_distance_preset", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_only_region_distance_changes(script, tmp_path):
    out = tmp_path / "rd.json"
    script.main(["--out", str(out)])
    cand, shipped = load_preset(out), load_preset("general")
    for n in (20, 50, 100, 113, 114, 128, 256, 512):
        for method in ("NDR-QL", "IQL"):
            ql_c, pc_c = cand.configs(method, grid=n)
            ql_s, pc_s = shipped.configs(method, grid=n)
            assert ql_c == ql_s
            want = 1 if (method == "NDR-QL" and n > 113) else 0
            assert pc_c.region_distance == want, (method, n)
            assert dataclasses.replace(pc_c, region_distance=0) == dataclasses.replace(pc_s, region_distance=0)


def test_a_grid_without_an_entry_is_refused(script, tmp_path):
    with pytest.raises(SystemExit, match="no NDR-QL entry at grid 64"):
        script.main(["--out", str(tmp_path / "x.json"), "--grids", "64"])
