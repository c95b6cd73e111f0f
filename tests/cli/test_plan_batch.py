"""``ndrql plan arena.map --scen arena.map.scen --all``: every scenario against its optimal length, JSON lines, resume."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ndrql.cli.plan_batch import parse_indices, summary
from ndrql.errors import NdrqlError
from ndrql.maps.astar import astar8

from helpers.cli import assert_one_line_error, run_cli

SCENARIOS = [((4, 4), (58, 58)), ((60, 3), (3, 60)), ((30, 2), (30, 61)), ((2, 40), (61, 20)), ((10, 50), (50, 12))]


@pytest.fixture
def arena(tmp_path):
    """A hand-drawn 64x64 MovingAI map with two walls and five scenarios (optimal octile lengths by A*)."""
    m = np.zeros((64, 64), dtype=bool)
    m[20:23, :48] = True
    m[42:45, 16:] = True
    m[0, :] = m[-1, :] = False
    rows = ["".join("@" if b else "." for b in row) for row in m]
    (tmp_path / "arena.map").write_text("type octile\nheight 64\nwidth 64\nmap\n" + "\n".join(rows) + "\n", encoding="ascii")
    lines = ["version 1"]
    for (sr, sc), (gr, gc) in SCENARIOS:  # .scen: x = column, y = row
        opt = astar8(m, (sr, sc), (gr, gc)).cost
        lines.append(f"0\tarena.map\t64\t64\t{sc}\t{sr}\t{gc}\t{gr}\t{opt:.8f}")
    (tmp_path / "arena.map.scen").write_text("\n".join(lines) + "\n", encoding="ascii")
    return tmp_path


def run(exe, cwd, *args):
    """``ndrql plan arena.map --scen arena.map.scen --method QL ARGS`` in ``cwd``."""
    return run_cli(exe, "plan", "arena.map", "--scen", "arena.map.scen", "--method", "QL", *args, cwd=cwd)


def test_all_scenarios_against_their_optimal_lengths(ndrql_exe, arena):
    r = run(ndrql_exe, arena, "--all", "--jsonl", "out.jsonl")
    assert r.returncode == 0, r.stderr
    lines = [x for x in r.stdout.splitlines() if x.startswith("scenario ")]
    assert len(lines) == len(SCENARIOS) and all(", ok, " in x for x in lines), r.stdout
    assert "scenarios: 5; success 5, path collides 0" in r.stdout
    assert "path octile cost / optimal over 5 successes" in r.stdout
    recs = [json.loads(x) for x in (arena / "out.jsonl").read_text().splitlines()]
    assert [x["scenario"] for x in recs] == list(range(5))
    for rec in recs:
        assert rec["success"] and rec["collisions"] == 0
        assert 0.999 <= rec["ratio"] < 1.3  # octile cost of the smoothed path vs the optimal octile length


def test_resume_skips_done_scenarios_and_a_cut_line(ndrql_exe, arena):
    assert run(ndrql_exe, arena, "--index", "0:2", "--jsonl", "out.jsonl").returncode == 0
    with open(arena / "out.jsonl", "a") as f:
        f.write('{"map": "arena.map", "scen')  # an interrupted write
    r = run(ndrql_exe, arena, "--all", "--jsonl", "out.jsonl")
    assert r.returncode == 0, r.stderr
    assert "resuming: 2 of 5 scenarios already in out.jsonl" in r.stdout
    assert sum(x.startswith("scenario ") for x in r.stdout.splitlines()) == 3
    recs = [json.loads(x) for x in (arena / "out.jsonl").read_text().splitlines()]
    assert sorted(x["scenario"] for x in recs) == list(range(5))
    r = run(ndrql_exe, arena, "--all", "--jsonl", "out.jsonl", "--seed", "1")  # another run: refused, file kept
    assert_one_line_error(r, "holds results of another run")


def test_batch_flags_are_checked(ndrql_exe, arena):
    for extra, needle in ((["--all", "--index", "1"], "either --all or --index"), (["--index", "3:9"], "outside"),
                          (["--all", "--seeds", "2"], "one method with one seed"), (["--jsonl", "x"], "for scenario batches")):
        r = run(ndrql_exe, arena, *extra)
        assert_one_line_error(r, needle)


def test_parse_indices_and_summary():
    assert parse_indices(None, 5, True) == [0, 1, 2, 3, 4]
    assert parse_indices("1:3", 5, False) == [1, 2] and parse_indices("3", 5, False) == [3]
    assert parse_indices(":2", 5, False) == [0, 1] and parse_indices("3:", 5, False) == [3, 4]
    with pytest.raises(NdrqlError):
        parse_indices("a:b", 5, False)
    lines = summary([{"success": True, "ratio": 1.0, "seconds": 1.0}, {"success": False, "collisions": 2},
                     {"success": False, "error": "x"}])
    assert lines[0] == "scenarios: 3; success 1, path collides 1, not converged or no path 0, errors 1"


def test_records_carry_steps_and_what_a_user_analyses(arena, capsys, monkeypatch):
    """In process: each record has the run's steps and episodes, success, status, ratio, method, scenario."""
    from ndrql.cli import main
    from ndrql.cli.plan_batch import FIELD_DOCS, OPTIONAL_FIELDS, RECORD_FIELDS

    monkeypatch.chdir(arena)
    assert main(["plan", "arena.map", "--scen", "arena.map.scen", "--method", "QL", "--index", "0:3",
                 "--jsonl", "r.jsonl"]) == 0
    out = capsys.readouterr().out
    assert "convergence steps over 3 successes: median " in out
    recs = [json.loads(x) for x in (arena / "r.jsonl").read_text().splitlines()]
    for k, rec in enumerate(recs):
        assert list(rec) == [f for f in RECORD_FIELDS if f in rec]  # the documented fields, in order
        assert set(RECORD_FIELDS) - set(rec) <= set(OPTIONAL_FIELDS) and set(FIELD_DOCS) == set(RECORD_FIELDS)
        assert rec["scenario"] == k and rec["method"] == rec["ran"] == "QL" and rec["status"] == "ok"
        assert rec["convergence_steps"] > 0 and rec["episodes"] >= rec["convergence_episode"] > 0
        assert rec["total_steps"] >= rec["convergence_steps"] and rec["success"] and rec["loop"] is False
        assert rec["ratio"] == pytest.approx(rec["octile"] / rec["optimal"], abs=1e-4) and rec["warnings"] == []


def test_warnings_name_their_scenario_in_map_pixels(arena, capsys, monkeypatch):
    """A start whose safe cell touches the wall is planned from the nearest free cell: the warning names the
    scenario and gives that cell's centre as a map pixel, and the record keeps it."""
    from ndrql.cli import main

    m = np.zeros((64, 64), dtype=bool)
    m[20:23, :48] = True
    m[42:45, 16:] = True
    opt = astar8(m, (23, 5), (58, 58)).cost
    (arena / "near.scen").write_text(f"version 1\n0\tarena.map\t64\t64\t5\t23\t58\t58\t{opt:.8f}\n"
                                     f"0\tarena.map\t64\t64\t5\t23\t58\t58\t{opt:.8f}\n")
    monkeypatch.chdir(arena)
    assert main(["plan", "arena.map", "--scen", "near.scen", "--method", "QL", "--all", "--size", "16",
                 "--jsonl", "n.jsonl"]) == 0
    err = capsys.readouterr().err
    said = [x for x in err.splitlines() if "touches an obstacle" in x]
    assert [x.split(": ")[2] for x in said] == ["scenario 0", "scenario 1"], err
    assert all("start 23,5:" in x and "centred at pixel " in x for x in said)
    recs = [json.loads(x) for x in (arena / "n.jsonl").read_text().splitlines()]
    assert all(len(r["warnings"]) == 1 and r["warnings"][0].startswith(f"scenario {r['scenario']}: start 23,5")
               for r in recs)


def test_a_long_or_looping_path_is_flagged_not_ok():
    from ndrql.cli.plan_batch import status, summary
    from ndrql.maps.lines import crosses_itself

    base = {"converged": True, "success": True, "octile": 10.0, "collisions": 0, "loop": False}
    assert status({**base, "ratio": 1.1}) == "ok"
    assert status({**base, "ratio": 1.5}) == "long"
    assert status({**base, "ratio": 1.1, "loop": True}) == "loop"
    assert status({**base, "ratio": 1.1, "collisions": 2}) == "collides"
    lines = summary([{**base, "ratio": 1.5, "status": "long"}, {**base, "ratio": 1.0, "status": "ok"}])
    assert "flagged among the successes: long 1" in lines[0]
    assert crosses_itself([(0, 0), (0, 5), (5, 5), (5, 2), (-1, 2)])  # a loop
    assert crosses_itself([(0, 0), (0, 5), (0, 3)])  # back the way it came
    assert not crosses_itself([(77, 43), (77, 42), (77, 47), (82, 47)])  # a start pixel's step back to its cell centre
    assert not crosses_itself([(0, 0), (0, 5), (5, 5), (5, 9)]) and not crosses_itself([(0, 0), (1, 1), (2, 2)])


def test_octile_doubt_allows_the_files_rounding_and_names_the_scenario(tmp_path):
    from ndrql.maps.readers import read_movingai_scen
    from ndrql.maps.scenarios import octile_distance, scenario_doubts

    o = octile_distance((0, 0), (1, 2))  # 2.41421356...
    rows = [f"{o:.3f}", f"{o - 0.0004:.3f}", f"{o:.8f}", f"{o - 0.001:.8f}"]  # 2.414, 2.414, exact, really short
    path = tmp_path / "a.map.scen"
    path.write_text("version 1\n" + "".join(f"0\ta.map\t5\t5\t2\t1\t0\t0\t{v}\n" for v in rows))
    scen = read_movingai_scen(path)
    assert scenario_doubts(scen[:3], "a.map", path) == []  # 3 decimals may lie 0.0005 below: no false warning
    (doubt,) = scenario_doubts(scen[2:], "a.map", path, numbers=[2, 3])
    assert "scenario 3 has an optimal length shorter" in doubt and "scenario 0" not in doubt
