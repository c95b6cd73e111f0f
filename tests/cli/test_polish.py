"""CLI polish: plain help, the subcommand's usage on a bad flag, aligned tables, quiet broken pipes, one figure style."""

from __future__ import annotations

import argparse
import re
import subprocess
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from ndrql.cli import build_parser
from ndrql.cli.text import plain, short_usage, text_table

from helpers import REPO_ROOT
from helpers.cli import assert_one_line_error, run_cli

SAMPLE = [str(REPO_ROOT / "src" / "ndrql" / "data" / "sample_map.png"), "--start", "25,179", "--goal", "167,5"]


def all_parsers(parser: argparse.ArgumentParser):
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in {id(p): p for p in action.choices.values()}.values():
                yield from all_parsers(sub)


def test_plain_removes_docstring_markup():
    assert plain("``None`` = 4 x cells") == "None = 4 x cells"
    assert plain("see :class:`~ndrql.planning.config.QLConfig` and :func:`ndrql.api.plan`") == "see QLConfig and plan"
    assert plain("Example::\n\n    ndrql train") == "Example:\n\n    ndrql train"
    assert plain("a ratio 3:2 and http://x") == "a ratio 3:2 and http://x"


def test_no_rst_markup_in_any_help():
    parsers = list(all_parsers(build_parser()))
    assert len(parsers) > 10
    for p in parsers:
        text = p.format_help()
        assert "``" not in text and not re.search(r"\w::\s*$", text, re.M), p.prog
        assert not re.search(r":(class|func|mod|data|meth):`", text), p.prog


def test_short_usage_names_the_subcommand():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert short_usage(sub.choices["plan"]) == "usage: ndrql plan [options] [MAP]"
    assert short_usage(parser) == "usage: ndrql [options] COMMAND ..."


@pytest.mark.parametrize("argv, usage", [
    (["plan", "--bogus"], "usage: ndrql plan [options] [MAP]; see ndrql plan --help"),
    (["astar", "--frob", "1"], "usage: ndrql astar [options] [MAP]; see ndrql astar --help"),
    (["map", "info", "--zzz"], "usage: ndrql map info [options] [MAP]; see ndrql map info --help"),
    (["plan", "--seeds", "x"], "usage: ndrql plan [options] [MAP]; see ndrql plan --help"),
])
def test_bad_flag_gives_the_subcommands_usage_in_one_line(ndrql_exe, argv, usage):
    r = run_cli(ndrql_exe, *argv)
    assert assert_one_line_error(r).endswith(f"({usage})") and r.stdout == ""


def test_closed_stdout_pipe_exits_quietly(ndrql_exe):
    """``ndrql astar ... | head -0``: the reader is gone before the first write; no traceback, exit 141."""
    with subprocess.Popen(ndrql_exe + ["astar", *SAMPLE, "--print-grid"], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE) as p:
        p.stdout.close()
        err = p.stderr.read().decode()
        assert p.wait() == 141
    assert err == ""


def test_text_table_columns_never_run_together():
    rows = [("QL", "10/10", f"{12_345_678:,}", "[11,000,000, 13,691,356]"), ("NDR-QL", "9/10", "75,995", "-")]
    lines = text_table(("method", "conv", "steps mean", "95% CI"), rows)
    assert set(lines[1]) == {"-"} and len(lines[1]) == len(lines[0])
    header, body = lines[0], lines[2:]
    ends = [m.end() for m in re.finditer(r"\S+(?= {2}|$)", header)]
    for line in body:
        assert len(line) == len(header)
        for end in ends[1:]:  # right-aligned columns end where their header ends
            assert line[end - 1] != " "
        assert "  " in line[len("NDR-QL"):]  # at least two spaces between cells
    with pytest.raises(ValueError, match="cells like the header"):
        text_table(("a", "b"), [("1",)])


def fake_run(method, steps, episodes):
    return SimpleNamespace(method=method, converged=True, convergence_steps=steps, convergence_episode=episodes,
                           length_ratio=1.05, shortest_success_length=150, longest_success_length=19_000)


def test_plan_table_with_eight_digit_steps():
    from ndrql.cli.plan_report import table

    runs = [fake_run("QL", s, 9_000) for s in (12_000_000, 15_500_000, 19_999_999)]
    runs += [fake_run("NDR-QL", s, 90) for s in (70_000, 80_000, 90_000)]
    lines = table(["QL", "NDR-QL"], runs)
    header = lines[0].split()
    assert header[:3] == ["method", "conv", "steps"]
    ql = lines[2].split("  ")
    cells = [c.strip() for c in ql if c.strip()]
    assert cells[0] == "QL" and cells[1] == "3/3" and cells[2] == "15,833,333" and cells[-1] == "150/19,000"
    assert len({len(line) for line in lines[:4]} - {len(lines[1])}) <= 1
    assert lines[-1].startswith("short/long: moves of the shortest and the longest training episode")


def test_dpi_flag_sets_the_figure_resolution(ndrql_exe, tmp_path):
    sizes = {}
    for dpi in (50, 100):
        out = tmp_path / f"a{dpi}.png"
        r = run_cli(ndrql_exe, "astar", *SAMPLE, "--png", str(out), "--dpi", str(dpi))
        assert r.returncode == 0, r.stderr
        with Image.open(out) as im:
            sizes[dpi] = im.size
    assert abs(sizes[100][0] - 2 * sizes[50][0]) <= 2
    r = run_cli(ndrql_exe, "astar", *SAMPLE, "--png", str(tmp_path / "x.png"), "--dpi", "5")
    assert assert_one_line_error(r) == "ndrql: error: --dpi must be an integer in 30..600, got 5"
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("workers, backend", [(1, "process"), (2, "process"), (2, "thread")])
def test_run_many_progress_bar_does_not_change_results(workers, backend, capsys):
    from ndrql.planning import PlanJob, run_many

    blocked = np.zeros((8, 10), dtype=bool)
    blocked[3, :8] = True
    jobs = [PlanJob(blocked, (0, 0), (7, 0), m, s) for m in ("QL", "IQL") for s in range(3)]
    plain_runs = run_many(jobs, workers=1)
    shown = run_many(jobs, workers=workers, backend=backend, progress=True)
    assert all(a.same_run(b) and (a.method, a.seed) == (j.method, j.seed) for a, b, j in zip(plain_runs, shown, jobs))
    assert capsys.readouterr().out == ""  # the bar never writes to stdout (and hides itself off a terminal)
