"""The ``belief`` preset: plan's constants on a map the planner does not fully know (NDR-QL's searched on belief maps)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import ndrql
from ndrql.planning.preset import BELIEF_PRESET, builtin_path, load_preset, plan_default_preset
from tests.helpers.belief_maps import GOAL, START, wall_map, wall_mask
from tests.helpers.cli import run_cli

pytestmark = pytest.mark.skipif(not builtin_path(BELIEF_PRESET).is_file(), reason="the belief preset is not installed")

METHODS = ("QL", "O-QL", "IQL", "IQL-BFS", "IQL-NDR", "NDR-QL")


def test_the_preset_loads_and_only_the_searched_methods_differ_from_general():
    belief, general = load_preset(BELIEF_PRESET), load_preset("general")
    assert belief.name == "belief" and belief.plan_default
    searched = belief.meta["searched"]["grids"]
    top = max(int(g) for g in searched)
    reference = belief.meta.get("reference")  # IQL-BFS's searched entries, when they won the check (the rule)
    moved = ("NDR-QL", "IQL-BFS") if reference else ("NDR-QL",)
    for grid in (None, 20, 50, 70, 100, 128, 256):
        for m in (x for x in METHODS if x not in moved):  # every other method: general's constants
            assert belief.configs(m, grid=grid) == general.configs(m, grid=grid), (m, grid)
    for m in moved:
        for grid in (int(g) for g in searched):
            assert belief.configs(m, grid=grid) != general.configs(m, grid=grid), (m, grid)
            pri, g_pri = belief.configs(m, grid=grid)[1], general.configs(m, grid=grid)[1]
            assert (pri.region_distance, pri.thd_tail, pri.mask_low) == (g_pri.region_distance, g_pri.thd_tail,
                                                                          g_pri.mask_low)
        for grid in (128, 256):  # above the searched grids: the top searched entry (never searched there)
            want = belief.configs(m, grid=top) if "top searched" in belief.meta.get("above", "") else \
                general.configs(m, grid=grid)
            assert belief.configs(m, grid=grid) == want, (m, grid)


def test_plan_default_preset_on_a_belief_map():
    assert plan_default_preset(None, partial=True) == "belief"
    assert plan_default_preset("belief", partial=True) == "belief"
    assert plan_default_preset(None) == plan_default_preset("general") == "general"
    assert plan_default_preset("paper", partial=True) == plan_default_preset("paper")  # the paper's weights: tuned


def test_the_request_takes_the_belief_preset_on_a_belief_map_and_an_explicit_one_wins():
    o, m = wall_map(), wall_mask()
    hidden = ndrql.build_request(o, START, GOAL, methods=["NDR-QL"], size=40, hide=m)
    known = ndrql.build_request(o, START, GOAL, methods=["NDR-QL"], size=40)
    given = ndrql.build_request(o, START, GOAL, methods=["NDR-QL"], size=40, hide=m, preset="general")
    assert (hidden.preset.name, known.preset.name, given.preset.name) == ("belief", "general", "general")
    assert hidden.info["preset"] == "belief" and given.info["preset"] == "general"
    belief, general = load_preset("belief"), load_preset("general")
    assert hidden.constants("NDR-QL", 40) == belief.configs("NDR-QL", grid=40) != general.configs("NDR-QL", grid=40)
    assert given.constants("NDR-QL", 40) == general.configs("NDR-QL", grid=40)
    assert hidden.constants("IQL-BFS", 40) == belief.configs("IQL-BFS", grid=40)  # the reference: the preset's
    assert known.constants("IQL-BFS", 40) == general.configs("IQL-BFS", grid=40)


def test_cli_and_api_name_the_same_preset_and_give_the_same_steps(ndrql_exe, tmp_path):
    mp, mask = tmp_path / "map.npy", tmp_path / "mask.npy"
    np.save(mp, wall_map())
    np.save(mask, wall_mask())
    base = ("plan", mp, "--start", "5,5", "--goal", "5,34", "--hide", mask, "--method", "NDR-QL", "--seeds", "1",
            "--size", "40", "--prior-from", "exact")
    r = run_cli(ndrql_exe, *base, "--json", tmp_path / "a.json")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "a.json").read_text())
    assert doc["preset"] == "belief" and "constants: preset belief" in r.stdout
    api = ndrql.solve(str(mp), start=START, goal=GOAL, methods=["NDR-QL"], seeds=1, size=40, hide=str(mask),
                      predictions="exact")
    assert api.info["preset"] == "belief"
    assert [x["total_steps"] for x in doc["runs"]] == [x.total_steps for x in api.results]
    r = run_cli(ndrql_exe, *base, "--preset", "general", "--json", tmp_path / "b.json")
    assert r.returncode == 0, r.stderr
    assert json.loads((tmp_path / "b.json").read_text())["preset"] == "general" and "constants: preset general" in r.stdout


def test_the_summary_names_the_preset_once_when_the_model_served(ndrql_exe, tmp_path):
    mp, mask = tmp_path / "map.npy", tmp_path / "mask.npy"
    np.save(mp, wall_map())
    np.save(mask, wall_mask())
    r = run_cli(ndrql_exe, "plan", mp, "--start", "5,5", "--goal", "5,34", "--hide", mask, "--method", "NDR-QL",
                "--seeds", "1", "--size", "40")
    assert r.returncode == 0, r.stderr
    assert "model: " in r.stdout and r.stdout.count("constants: preset belief") == 1, r.stdout
