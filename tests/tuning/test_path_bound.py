"""Path quality is part of a preset's check: no shipped preset's greedy path exceeds the grid optimum by more
than PATH_BOUND on the worst map of its tuning set, and an export refuses constants that do."""

from __future__ import annotations

import json
import math

import pytest

from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.preset import builtin_path, load_preset
from ndrql.tuning.objective import PATH_BOUND, Evaluation
from ndrql.tuning.report import check_presets, path_verdict


def test_path_quality_by_hand():
    ev = Evaluation()
    ev.add("a", [(True, 100, 1.0), (True, 120, 1.2)])  # map mean 1.1
    ev.add("b", [(True, 100, 1.5), (False, 900, math.nan)])  # map mean 1.5 (the converged run only)
    ev.add("c", [(False, 900, math.nan)])  # no run converged: an infinite ratio, the worst map
    q = ev.path_quality()
    assert q["worst_run"] == 1.5 and q["worst_map"] == math.inf
    assert q["p95_map"] == math.inf  # 3 maps: the value at or above 95% of them is the worst
    ev.runs.pop("c")
    for i in range(19):
        ev.add(f"d{i}", [(True, 100, 1.0)])
    q = ev.path_quality()  # 21 maps: 19 at 1.0, then 1.1 and 1.5; the 95th percentile (position 0.95 x 20 = 19) is 1.1
    assert q["worst_map"] == pytest.approx(1.5) and q["p95_map"] == pytest.approx(1.1)
    assert ev.summary()["worst_map"] == q["worst_map"]


def test_the_verdict_names_every_method_over_the_bound():
    rec = {"grids": {"50": {"IQL": {"worst_map": 1.1}, "QL": {"worst_map": PATH_BOUND + 0.01}},
                     "100": {"NDR-QL": {"worst_map": math.inf}}}}
    lines = path_verdict(rec)
    assert len(lines) == 2 and lines[0].startswith("grid 50 QL: worst map") and "grid 100 NDR-QL" in lines[1]
    assert path_verdict({"grids": {"50": {"IQL": {"worst_map": PATH_BOUND}}}}) == []
    # the paper's constants are reported, not judged: spec's QL is exempt, a searched entry is not
    spec, tuned = load_preset("spec"), load_preset("tuned")
    over = {"grids": {"50": {"QL": {"worst_map": PATH_BOUND + 0.1}}}}
    assert path_verdict(over, spec) == [] and len(path_verdict(over, tuned)) == 1


def test_an_export_does_not_adopt_constants_whose_worst_map_exceeds_the_bound(monkeypatch):
    """Fewer steps, paths no worse on average, but one map far over the bound: the spec constants stay."""
    import ndrql.tuning.report as R
    from ndrql.planning.preset import MethodSetting

    def fake_evaluate(problems, method, seeds, ql, pc, pool=None):
        ev = Evaluation()
        tuned = ql.alpha != QLConfig().alpha
        for i in range(20):
            ratio = 1.02 if not tuned or i else PATH_BOUND + 0.2  # one bad map for the tuned constants
            ev.add(f"m{i}", [(True, 500 if tuned else 1000, ratio - (0.01 if tuned and i else 0.0))] * 2)
        return ev, ""

    monkeypatch.setattr(R, "evaluate", fake_evaluate)
    setting = MethodSetting(QLConfig(alpha=0.3), PriorConfig())
    check = check_presets([], ["IQL"], {"IQL": setting}, [5, 6], objective="geomean")["IQL"]
    assert check["tuned"]["geomean"] < check["spec"]["geomean"] and check["tuned"]["worst_map"] > PATH_BOUND
    assert not check["tuned_wins"]


def test_an_export_falls_through_to_the_next_best_constants_that_win(monkeypatch):
    """The best trial breaks the bound on fresh seeds, the second does too, the third wins: it is adopted
    (candidate 2, three checked), and SPEC is run once."""
    import ndrql.tuning.report as R
    from ndrql.planning.preset import MethodSetting

    calls = []

    def fake_evaluate(problems, method, seeds, ql, pc, pool=None):
        calls.append(ql.alpha)
        ev = Evaluation()
        bad = ql.alpha in (0.3, 0.31)  # the best two: fewer steps, one map over the bound
        for i in range(20):
            steps = 1000 if ql.alpha == QLConfig().alpha else 400 if bad else 450
            ratio = PATH_BOUND + 0.2 if bad and i == 0 else 1.02
            ev.add(f"m{i}", [(True, steps, ratio)] * 2)
        return ev, ""

    monkeypatch.setattr(R, "evaluate", fake_evaluate)
    settings = [MethodSetting(QLConfig(alpha=a), PriorConfig()) for a in (0.3, 0.31, 0.32, 0.33)]
    check = check_presets([], ["IQL"], {"IQL": settings[0]}, [5, 6], objective="geomean",
                          alternates={"IQL": settings[1:]})["IQL"]
    assert check["tuned_wins"] and check["candidate"] == 2 and check["candidates_checked"] == 3
    assert check["tuned"]["worst_map"] <= PATH_BOUND
    assert calls == [QLConfig().alpha, 0.3, 0.31, 0.32]  # SPEC once, then in order; the fourth never run
    # without alternates the best alone is judged, as before
    only = check_presets([], ["IQL"], {"IQL": settings[0]}, [5, 6], objective="geomean")["IQL"]
    assert not only["tuned_wins"] and only["candidate"] == 0 and only["candidates_checked"] == 1


_IQL_OVER = ("IQL keeps grid 100's constants of its first search above 70 cells (2.83 times the optimum on one tune "
             "map at grid 100; over the bound on large-dev2-128 at 128 cells too, with or without the epsilon sweep): "
             "the bounded search's adopted point took 30x the steps at 256 cells and 2.27x at 128 "
             "(docs/results.md#path-quality). Strict: once the entry passes, this mark must go.")
IQL_OVER = pytest.mark.xfail(strict=True, reason=_IQL_OVER)


def _entries():
    """Every (preset, grid, method) a shipped preset holds; IQL's entries above grid 50 of ``general`` are the known
    exceptions."""
    out = []
    for name in ("general", "tuned"):
        preset = load_preset(name)
        grids = {str(n): preset.grids[n] for n in sorted(preset.grids)} or {None: preset.methods}
        for grid, methods in grids.items():
            for m in sorted(methods):
                marks = [IQL_OVER] if (name, m) == ("general", "IQL") and grid not in (None, "50") else []
                out.append(pytest.param(name, grid, m, marks=marks, id=f"{name}-{grid or 50}-{m}"))
    return out


@pytest.mark.parametrize(("name", "grid", "method"), _entries())
def test_every_shipped_preset_keeps_its_worst_map_within_the_bound(name, grid, method):
    """The record is measured by tools/preset_path_check.py on the preset's own tuning set and check seeds."""
    rec = json.loads(builtin_path(name).read_text())["meta"].get("path_quality")
    assert rec is not None, f"run tools/preset_path_check.py {name}"
    preset = load_preset(name)
    grids = [str(n) for n in sorted(preset.grids)] or ["50"]
    assert sorted(rec["grids"]) == sorted(grids) and rec["bound"] == PATH_BOUND
    for n in grids:
        methods = preset.grids[int(n)] if preset.grids else preset.methods
        assert set(rec["grids"][n]) == set(methods)
    judged = {**rec, "grids": {grid or "50": {method: rec["grids"][grid or "50"][method]}}}
    assert path_verdict(judged, preset) == [], path_verdict(judged, preset)


def test_a_search_counts_a_trial_over_the_bound_as_infeasible():
    from ndrql.tuning.study import CONSTRAINTS, _constraint_values

    ev = Evaluation()
    ev.add("a", [(True, 100, 1.0), (True, 100, 1.1)])
    ev.add("b", [(True, 100, PATH_BOUND + 0.5), (True, 100, PATH_BOUND + 0.3)])  # worst map: bound + 0.4
    c = _constraint_values(ev, {"ratio": 10.0, "not_converged": 0})
    assert set(c) == set(CONSTRAINTS) and c["c_worst_map"] == pytest.approx(0.4) and c["c_ratio"] < 0
    ev.runs["b"] = [(True, 100, 1.2)]
    assert _constraint_values(ev, {"ratio": 10.0, "not_converged": 0})["c_worst_map"] == pytest.approx(1.2 - PATH_BOUND)
