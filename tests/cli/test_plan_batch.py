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
