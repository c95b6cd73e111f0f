"""One request, one truth: ``ndrql plan`` and ``ndrql.solve`` give the same plan for the same request.

Each row is one request written twice, as ``plan`` flags and as API keywords; the CLI's JSON and the
API's report must agree exactly on what was planned (grid, methods asked and run, thresholds, steps,
paths on the grid and on the map, constants). Most rows run the CLI in this process
(:func:`ndrql.cli.main`), two through the real console script. The maps are drawn here, small: a PNG,
a ``.npy``, a ROS ``map_server`` map with 2 px walls, unknown space and a resolution, a MovingAI
``.map`` with a scenario file.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import ndrql
from ndrql.cli import main as cli_main
from ndrql.errors import FallbackWarning, NdrqlError
from ndrql.maps.astar import astar8
from ndrql.pipeline.settings import PlanSettings
from ndrql.planning.config import QLConfig
from ndrql.planning.preset import load_preset, plan_default_preset

from helpers.cli import run_cli

#: Seeds per row: enough to compare, few enough to stay fast.
SEEDS = 2


def _rooms(side: int = 72) -> np.ndarray:
    """Two rooms split by a 2 px wall with a door, and a 2 px inner wall with a gap."""
    m = np.zeros((side, side), dtype=bool)
    m[:, 34:36] = True
    m[44:52, 34:36] = False  # door
    m[20:22, :26] = True  # inner wall, open at its right end
    return m


@pytest.fixture(scope="module")
def maps(tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("matrix")
    m = _rooms()
    Image.fromarray(np.where(m, 0, 255).astype(np.uint8)).save(root / "rooms.png")
    np.save(root / "rooms.npy", m)
    gray = np.where(m, 0, 254).astype(np.uint8)
    gray[:, 66:] = 205  # unknown strip: an obstacle to the planner
    Image.fromarray(gray).save(root / "flat.pgm")
    (root / "flat.yaml").write_text("image: flat.pgm\nresolution: 0.05\norigin: [-1.0, -2.0, 0.0]\nnegate: 0\n"
                                    "occupied_thresh: 0.65\nfree_thresh: 0.196\n", encoding="utf-8")
    rows = ["".join("@" if b else "." for b in row) for row in m]
    (root / "arena.map").write_text(f"type octile\nheight {m.shape[0]}\nwidth {m.shape[1]}\nmap\n" + "\n".join(rows)
                                    + "\n", encoding="ascii")
    lines = ["version 1"]
    for (sr, sc), (gr, gc) in (((5, 5), (65, 60)), ((10, 60), (60, 10)), ((30, 5), (5, 60))):
        lines.append(f"0\tarena.map\t72\t72\t{sc}\t{sr}\t{gc}\t{gr}\t{astar8(m, (sr, sc), (gr, gc)).cost:.8f}")
    (root / "arena.map.scen").write_text("\n".join(lines) + "\n", encoding="ascii")
    # a region that joins start and goal at no Eq. 7 threshold: uninformative, the fallback fires
    np.savez(root / "flat.npz", region=np.zeros(m.shape), guideline=np.full(m.shape, 0.2))
    return {"png": root / "rooms.png", "npy": root / "rooms.npy", "ros": root / "flat.yaml", "map": root / "arena.map",
            "scen": root / "arena.map.scen", "flat": root / "flat.npz", "root": root}


#: (name, plan flags, API keywords); ``{png}`` etc. are filled with the maps' paths.
ROWS = [
    ("png-pixels-NDR-QL", ["{png}", "--start", "5,5", "--goal", "65,60"],
     dict(map="png", start=(5, 5), goal=(65, 60))),
    ("npy-QL-IQL-compare", ["{npy}", "--start", "5,5", "--goal", "65,60", "--compare", "QL,IQL,NDR-QL"],
     dict(map="npy", start=(5, 5), goal=(65, 60), methods=["QL", "IQL", "NDR-QL"])),
    ("ros-world-radius", ["{ros}", "--start-world=-0.7,1.2", "--goal-world", "1.9,-1.4,1.57",
                          "--robot-radius", "0.05"],
     dict(map="ros", start_world=(-0.7, 1.2), goal_world=(1.9, -1.4, 1.57), robot_radius=0.05)),
    ("ros-world-settings-object", ["{ros}", "--start-world=-0.7,1.2", "--goal-world", "1.9,-1.4", "--robot-radius", "0.05",
                                   "--method", "IQL"],
     dict(map="ros", start_world=(-0.7, 1.2), goal_world=(1.9, -1.4), methods=["IQL"],
          settings=PlanSettings(robot_radius=0.05))),
    ("movingai-scenario", ["{map}", "--scen", "{scen}:1"],
     dict(map="map", scen="{scen}:1")),
    ("movingai-scenario-index", ["{map}", "--scen", "{scen}", "--index", "2", "--method", "IQL"],
     dict(map="map", scen="{scen}", scen_index=2, methods=["IQL"])),
    ("area-grid-compare", ["{png}", "--start", "5,5", "--goal", "65,60", "--grid", "area", "--size", "24",
                           "--compare", "QL,NDR-QL"],
     dict(map="png", start=(5, 5), goal=(65, 60), grid="area", size=24, methods=["QL", "NDR-QL"])),
    ("weights-paper", ["{npy}", "--start", "5,5", "--goal", "65,60", "--weights", "paper"],
     dict(map="npy", start=(5, 5), goal=(65, 60), weights="paper")),
    ("weights-general-preset-override", ["{npy}", "--start", "5,5", "--goal", "65,60", "--weights", "general",
                                         "--guideline-ties", "0", "--alpha", "0.1"],
     dict(map="npy", start=(5, 5), goal=(65, 60), weights="general", priors={"guideline_ties": 0.0},
          ql={"alpha": 0.1})),
    ("fallback-fires", ["{npy}", "--start", "5,5", "--goal", "65,60", "--prior-from", "{flat}"],
     dict(map="npy", start=(5, 5), goal=(65, 60), predictions="{flat}")),
    ("fallback-none", ["{npy}", "--start", "5,5", "--goal", "65,60", "--prior-from", "{flat}", "--fallback", "none"],
     dict(map="npy", start=(5, 5), goal=(65, 60), predictions="{flat}", fallback=None)),
    ("oracle-safe-size", ["{png}", "--start", "5,5", "--goal", "65,60", "--prior-from", "oracle", "--size", "18"],
     dict(map="png", start=(5, 5), goal=(65, 60), predictions="oracle", size=18)),
    ("prior-from-model", ["{npy}", "--start", "5,5", "--goal", "65,60", "--prior-from", "model"],
     dict(map="npy", start=(5, 5), goal=(65, 60), predictions="model")),
    ("prior-from-exact-compare", ["{png}", "--start", "5,5", "--goal", "65,60", "--prior-from", "exact",
                                  "--compare", "IQL-BFS,NDR-QL"],
     dict(map="png", start=(5, 5), goal=(65, 60), predictions="exact", methods=["IQL-BFS", "NDR-QL"])),
]

ROW = {r[0]: r for r in ROWS}

#: What must agree between the CLI's JSON and the API's report.
KEYS = ("planning_size", "grid", "start", "goal", "source_start", "source_goal", "astar_length", "methods",
        "requested_methods", "seeds", "config", "prior_config", "ndr_qi_threshold", "ndr_qi_threshold_reason",
        "fallback", "planning_grid", "preset", "prediction_quality", "request", "policy")
RUN_KEYS = ("method", "requested_method", "fallback_reason", "seed", "converged", "convergence_episode",
            "convergence_steps", "episodes", "total_steps", "path", "path_length", "length_ratio", "path_pixels",
            "collisions", "path_world", "success")


def _fill(value, maps):
    if isinstance(value, str):
        return value.format(**{k: str(v) for k, v in maps.items()})
    return value


def _api(kw: dict, maps: dict) -> dict:
    kw = {k: _fill(v, maps) for k, v in kw.items()}
    source = maps[kw.pop("map")]
    kw.setdefault("seeds", SEEDS)
    if isinstance(kw.get("predictions"), str) and kw["predictions"] not in ("oracle", "model", "exact"):
        kw["predictions"] = ndrql.api.load_predictions(kw["predictions"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        report = ndrql.solve(str(source), workers=1, **kw)
    return json.loads(json.dumps(report.to_dict(), default=str))


def _cli(flags: list[str], maps: dict, tmp_path: Path, capsys) -> dict:
    out = tmp_path / "plan.json"
    argv = ["plan", *[_fill(f, maps) for f in flags], "--seeds", str(SEEDS), "--workers", "1", "--json", str(out)]
    code = cli_main(argv)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return json.loads(out.read_text())


def _same(cli: dict, api: dict, name: str) -> None:
    for k in KEYS:
        assert cli.get(k) == api.get(k), f"{name}: {k} differs: CLI {cli.get(k)!r} vs API {api.get(k)!r}"
    assert len(cli["runs"]) == len(api["runs"])
    for a, b in zip(cli["runs"], api["runs"]):
        for k in RUN_KEYS:
            assert a.get(k) == b.get(k), f"{name}: run {a['method']} seed {a['seed']}: {k} differs"
        assert (a.get("route") or {}).get("pixels") == (b.get("route") or {}).get("pixels"), f"{name}: final path"
    untimed = lambda d: [{k: v for k, v in t.items() if k != "seconds"} for t in d.get("sources") or []]  # noqa: E731
    assert untimed(cli) == untimed(api), f"{name}: sources differ"


@pytest.mark.parametrize("name,flags,kw", ROWS, ids=[r[0] for r in ROWS])
def test_cli_and_api_make_the_same_plan(name, flags, kw, maps, tmp_path, capsys):
    cli = _cli(flags, maps, tmp_path, capsys)
    api = _api(kw, maps)
    _same(cli, api, name)
    assert cli["runs"], name


def test_the_rows_cover_what_the_issue_asks(maps, tmp_path, capsys):
    """The matrix is not vacuous: the fallback fires in one row and not in another, the scenario is used,
    both grid rules and both weights appear, and a world request writes world poses."""
    fired = _api(dict(ROW["fallback-fires"][2]), maps)
    assert fired["methods"] == ["IQL-BFS"] and fired["requested_methods"] == ["NDR-QL"]
    assert fired["runs"][0]["requested_method"] == "NDR-QL" and "uninformative" in fired["runs"][0]["fallback_reason"]
    assert fired["policy"] == ["file"] and fired["sources"][0]["accepted"] is False
    kept = _api(dict(ROW["fallback-none"][2]), maps)
    assert kept["methods"] == ["NDR-QL"] and kept["runs"][0]["fallback_reason"] is None
    default = _api(dict(ROW["png-pixels-NDR-QL"][2]), maps)  # a map the planner knows: the exact prior
    assert default["policy"] == ["exact"] and default["sources"][0]["accepted"] and default["methods"] == ["NDR-QL"]
    assert _api(dict(ROW["prior-from-model"][2]), maps)["policy"] == ["model"]
    scen = _api(dict(ROW["movingai-scenario"][2]), maps)
    assert scen["source_start"] == [10, 60] and scen["source_goal"] == [60, 10] and scen["scenario"]["index"] == 1
    assert _api(dict(ROW["area-grid-compare"][2]), maps)["planning_grid"]["rule"] == "area"
    world = _api(dict(ROW["ros-world-radius"][2]), maps)
    assert world["planning_grid"]["rule"] == "safe" and world["planning_grid"]["robot_radius_px"] == 1.0
    assert world["runs"][0]["path_world"][-1][2] == pytest.approx(1.57)
    assert _api(dict(ROW["weights-paper"][2]), maps)["preset"] == plan_default_preset("paper")
    assert _api(dict(ROW["png-pixels-NDR-QL"][2]), maps)["preset"] == plan_default_preset("general")


@pytest.mark.parametrize("row", ["png-pixels-NDR-QL", "movingai-scenario"])
def test_the_console_script_agrees_too(row, maps, tmp_path, ndrql_exe):
    name, flags, kw = ROW[row]
    out = tmp_path / "plan.json"
    r = run_cli(ndrql_exe, "plan", *[_fill(f, maps) for f in flags], "--seeds", str(SEEDS), "--workers", "1",
                "--json", out)
    assert r.returncode == 0, r.stderr
    _same(json.loads(out.read_text()), _api(kw, maps), name)


def test_preset_follows_the_resolved_weights_file(maps, monkeypatch):
    """``NDRQL_WEIGHTS=paper`` with no flag: the paper model and the constants searched for it (the model where the
    request asks for it; on a known map the default policy needs no model, and keeps the weights' preset)."""
    monkeypatch.setenv("NDRQL_WEIGHTS", "paper")
    req = ndrql.build_request(str(maps["npy"]), (5, 5), (65, 60), predictions="model")
    assert req.weights_file.endswith("ndr_default.pt") and req.preset.name == plan_default_preset("paper")
    default = ndrql.build_request(str(maps["npy"]), (5, 5), (65, 60))
    assert default.sources == ("exact",) and default.weights_file is None
    assert default.preset.name == plan_default_preset("paper")
    monkeypatch.delenv("NDRQL_WEIGHTS")
    assert ndrql.build_request(str(maps["npy"]), (5, 5), (65, 60)).preset.name == plan_default_preset("general")


def test_a_field_set_to_its_default_is_still_set(maps):
    """A preset's value can be set back to the paper's: explicit fields are set, not "differ from the default"."""
    general = load_preset("general")
    ties = {general.configs("NDR-QL", grid=n)[1].guideline_ties for n in (*general.grids, None)}
    assert ties != {0.0}, "the general preset no longer sets guideline_ties; pick another field for this test"
    req = ndrql.build_request(str(maps["npy"]), (5, 5), (65, 60), preset="general", priors={"guideline_ties": 0.0})
    assert all(req.constants("NDR-QL", n)[1].guideline_ties == 0.0 for n in (16, 50, 100, 200))
    assert req.set_fields["priors"] == {"guideline_ties": 0.0}


def test_the_readme_example_runs_ndr_ql_or_warns(maps):
    """The README's example shape: either NDR-QL runs, or a FallbackWarning names both methods."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = ndrql.plan(str(maps["png"]), start=(5, 5), goal=(65, 60), workers=1)
    fb = [w for w in caught if issubclass(w.category, FallbackWarning)]
    if run.method == "NDR-QL":
        assert not fb and run.requested_method == "NDR-QL"
    else:
        assert fb and "NDR-QL" in str(fb[0].message) and run.method in str(fb[0].message)
        assert run.requested_method == "NDR-QL" and run.fallback_reason


@pytest.mark.parametrize("kw,needle", [
    (dict(start=(5, 5), goal=(65, 60), scen="{scen}:1"), "a scenario gives start and goal"),
    (dict(scen="{scen}:1", scen_index=1), "not both"),
    (dict(start=(5, 5)), "no goal given"),
    (dict(start=(5, 5), goal=(65, 60), preset="spec", config=QLConfig()), "not both"),
    (dict(start=(5, 5), goal=(65, 60), priors={"r_maxx": 1}), "unknown prior constant 'r_maxx'"),
    (dict(start=(5, 5), goal=(65, 60), gird="safe"), "unknown plan option 'gird'"),
])
def test_the_api_refuses_what_it_would_ignore(kw, needle, maps):
    kw = {k: _fill(v, maps) for k, v in kw.items()}
    with pytest.raises(NdrqlError, match=needle):
        ndrql.build_request(str(maps["map"]), **kw)


def test_a_scenario_with_a_map_that_is_not_movingai_is_an_error(maps, capsys):
    with pytest.raises(NdrqlError, match="MovingAI"):
        ndrql.build_request(str(maps["npy"]), scen=f"{maps['scen']}:0")
    code = cli_main(["plan", str(maps["map"]), "--start", "5,5", "--goal", "65,60", "--scen", f"{maps['scen']}:2"])
    assert code == 2 and "--scen gives start and goal" in capsys.readouterr().err


def test_a_fallback_is_named_in_the_summary_the_json_the_warning_and_the_figure(maps, tmp_path, capsys):
    from ndrql.viz.plan import plan_figure

    out = tmp_path / "fb.json"
    code = cli_main(["plan", str(maps["npy"]), "--start", "5,5", "--goal", "65,60", "--prior-from", str(maps["flat"]),
                     "--workers", "1", "--json", str(out)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "IQL-BFS (fallback for NDR-QL) seed 0" in captured.out and "fell back to IQL-BFS" in captured.out
    assert "did not run" not in captured.err  # the CLI names it once, in the summary (the API warns)
    run = json.loads(out.read_text())["runs"][0]
    assert run["method"] == "IQL-BFS" and run["requested_method"] == "NDR-QL" and run["fallback_reason"]
    with pytest.warns(FallbackWarning):
        report = ndrql.solve(str(maps["npy"]), (5, 5), (65, 60), predictions=ndrql.api.load_predictions(maps["flat"]),
                             workers=1)
    titles = [ax.get_title() for ax in plan_figure(report).axes]
    assert any("IQL-BFS (fallback for NDR-QL)" in t for t in titles), titles


def test_every_command_shares_the_grid_size_bounds(maps, capsys):
    from ndrql.limits import MAX_GRID_SIZE, MIN_GRID_SIZE

    for argv in (["astar", str(maps["npy"]), "--start", "5,5", "--goal", "65,60"],
                 ["map", "info", str(maps["npy"])],
                 ["plan", str(maps["npy"]), "--start", "5,5", "--goal", "65,60", "--method", "QL", "--max-size", "1024"],
                 ["predict", str(maps["npy"]), "--start", "5,5", "--goal", "65,60", "--out", "/nonexistent/x"]):
        for size in (MIN_GRID_SIZE - 1, MAX_GRID_SIZE + 1):
            assert cli_main([*argv, "--size", str(size)]) == 2, argv
            err = capsys.readouterr().err
            assert err.startswith("ndrql: error: ") and str(size) in err, (argv, err)


@pytest.mark.parametrize("argv,needle", [
    (["{npy}", "--start", "5,5", "--goal", "65,60", "--invert"], "invert read image files"),
    (["{png}", "--start", "5,5", "--goal", "65,60", "--crop"], "crop cuts a ROS map"),
    (["{npy}", "--start", "5,5", "--goal", "65,60", "--method", "QL", "--prior-from", "oracle"], "none of QL uses them"),
    (["{map}", "--start", "5,5", "--goal", "65,60", "--scen", "{scen}"], "--scen gives start and goal"),
    (["{npy}", "--scen", "{scen}:0"], "MovingAI"),
    (["{ros}", "--start-world=0.72,1.0", "--goal", "60,60"], "m is on an obstacle or in unknown space"),
    (["{ros}", "--start-world=2.4,1.0", "--goal", "60,60"], "m is on an obstacle or in unknown space"),
])
def test_plan_refuses_options_the_request_would_ignore(argv, needle, maps, capsys):
    assert cli_main(["plan", *[_fill(a, maps) for a in argv]]) == 2
    err = capsys.readouterr().err
    assert err.startswith("ndrql: error: ") and needle in err and err.count("\n") == 1, err
