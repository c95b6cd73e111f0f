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
            want = 1 if method == "NDR-QL" else 0  # the shipped preset has it at every grid since 2026-11-27
            assert pc_c.region_distance == want, (method, n)
            assert dataclasses.replace(pc_c, region_distance=0) == dataclasses.replace(pc_s, region_distance=0)


def test_a_grid_without_an_entry_is_refused(script, tmp_path):
    with pytest.raises(SystemExit, match="no NDR-QL entry at grid 64"):
        script.main(["--out", str(tmp_path / "x.json"), "--grids", "64"])


@pytest.fixture(scope="module")
def variant_script():
    spec = importlib.util.spec_from_file_location("preset_variant", SCRIPT.parent / "preset_variant.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_a_variant_changes_only_the_constants_set_on_the_grids_asked(variant_script, tmp_path):
    out = tmp_path / "v.json"
    variant_script.main(["--out", str(out), "--set", "thd_tail=1", "--set", "mask_low=-20", "--grids", "128"])
    cand, shipped = load_preset(out), load_preset("general")
    for n in (50, 100, 113, 114, 128, 181, 182, 256):  # the grid-128 entry serves 114-181 cells, the grid-256 one above
        for method in ("NDR-QL", "IQL"):
            (ql_c, pc_c), (ql_s, pc_s) = cand.configs(method, grid=n), shipped.configs(method, grid=n)
            assert ql_c == ql_s
            if method == "NDR-QL" and 113 < n <= 181:
                assert (pc_c.thd_tail, pc_c.mask_low) == (1, -20.0)
                assert dataclasses.replace(pc_c, thd_tail=pc_s.thd_tail, mask_low=pc_s.mask_low) == pc_s
            else:
                assert pc_c == pc_s, (method, n)
    with pytest.raises(SystemExit, match="not a prior constant a preset may set: alpha"):
        variant_script.main(["--out", str(out), "--set", "alpha=0.5"])
