"""``ndrql tune --maps generated``: problems from a held-out generated set on the safe grid, a search
that starts from a preset's constants, and a preset with one entry per grid size."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from ndrql.errors import NdrqlError
from ndrql.maps.astar import astar4
from ndrql.planning.preset import load_preset
from ndrql.tuning import space as S

from helpers.cli import assert_one_line_error, run_cli

pytestmark = pytest.mark.slow


def test_interleave_takes_families_in_turn():
    from ndrql.experiments.tune_maps import interleave

    got = interleave({"b": [1, 4, 5], "a": [0, 2], "c": [3]}, 5)
    assert got == [("a", 0), ("b", 1), ("c", 3), ("a", 2), ("b", 4)]
    assert interleave({"a": [0]}, 9) == [("a", 0)]


def test_generated_problems_on_the_safe_grid(tmp_path, monkeypatch):
    from ndrql.experiments.tune_maps import generated_problems

    monkeypatch.setenv("NDRQL_CACHE", str(tmp_path / "cache"))
    with pytest.raises(NdrqlError, match="tune on 'tune'"):
        generated_problems(4, 32, "general", "transfer")
    problems, skipped, digest = generated_problems(6, 32, "general", "transfer-small")
    assert len(problems) == 6 and len({p.category for p in problems}) == 6  # family by family
    # the weights' digest, and the orientations plan averages over (they change the priors)
    # (plan's default is one orientation: no "-sN" suffix)
    assert len(digest) == 16 and "-s" not in digest and all(k.startswith("transfer-small-g32-") for k in skipped)
    for p in problems:
        assert p.key.startswith("transfer-small-g32-") and max(p.blocked.shape) in (32, 40, 50, 64)
        assert p.region.shape == p.guideline.shape == p.blocked.shape
        assert not p.blocked[p.start] and not p.blocked[p.goal]
        assert p.astar == astar4(p.blocked, p.start, p.goal).moves > 0
        assert np.all((p.region >= 0) & (p.region <= 1))
    again, _, _ = generated_problems(6, 32, "general", "transfer-small")
    assert [p.key for p in again] == [p.key for p in problems]  # same set, same order
    assert all(np.array_equal(a.region, b.region) for a, b in zip(again, problems))


def test_tune_generated_end_to_end_and_per_grid_preset(tmp_path, ndrql_exe):
    env = {**os.environ, "NDRQL_CACHE": str(tmp_path / "cache")}
    common = ["--maps", "generated", "--eval-set", "transfer-small", "--weights", "general", "--trials", "3",
              "--samples", "4", "--seeds", "1", "--workers", "1", "--start-from", "tuned", "--out", str(tmp_path / "t"),
              "--no-progress"]
    for n in ("32", "64"):
        r = run_cli(ndrql_exe, "tune", "--method", "IQL", "--grid", n, *common, env=env)
        assert r.returncode == 0, r.stderr
        assert f"4 problems of set 'transfer-small' on the safe grid of {n} cells" in r.stderr
        assert "(geometric mean)" in r.stdout
    trials = json.loads((tmp_path / "t" / "IQL" / "trials.json").read_text())
    assert trials[0]["user_attrs"]["spec"] is True
    ql, pc = load_preset("tuned").configs("IQL")
    want = S.params_of("IQL", ql, pc)
    assert trials[1]["params"] == pytest.approx(want)  # trial 1: the start point
    out = tmp_path / "general-test.json"
    r = run_cli(ndrql_exe, "tune", "--export-preset", str(out), "--methods", "IQL", "--grids", "32,64", *common, env=env)
    assert r.returncode == 0, r.stderr
    data = json.loads(out.read_text())
    assert data["version"] == 2 and sorted(data["grids"]) == ["32", "64"] and data["name"] == "general-test"
    assert data["meta"]["objective"] == "geomean" and set(data["meta"]["grids"]) == {"32", "64"}
    preset = load_preset(out)
    assert preset.configs("IQL", grid=40) == preset.configs("IQL", grid=32)
    assert preset.configs("IQL", grid=100) == preset.configs("IQL", grid=64)
    # the check on fresh seeds is per grid, with the search's objective
    assert data["meta"]["grids"]["64"]["validation_check"]["IQL"]["objective"] == "geomean"
    assert_one_line_error(run_cli(ndrql_exe, "tune", "--method", "IQL", "--maps", "generated", "--eval-set", "select",
                                  "--out", str(tmp_path / "t"), env=env), "tune on 'tune'")
    assert_one_line_error(run_cli(ndrql_exe, "tune", "--method", "IQL", "--start-from", "nope",
                                  "--out", str(tmp_path / "t"), env=env), "unknown preset 'nope'")
