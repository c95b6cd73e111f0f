"""No output can destroy an input: the output guard through the real console script, and its rules directly.

Every refused case: exit code 2, one ``ndrql: error:`` line, and every file in the folder byte for
byte as before (no new file either).
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ndrql.errors import OutputError
from ndrql.io.guard import Input, Output, check_outputs
from ndrql.io.jsonl import BatchLog

from helpers.cli import assert_one_line_error, run_cli

POINTS = ("--start", "1,1", "--goal", "90,100")


def snapshot(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` (links as their target) and its digest."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if ".cache" in p.parts:
            continue
        if p.is_symlink():
            out[str(p.relative_to(folder))] = "-> " + os.readlink(p)
        elif p.is_file():
            out[str(p.relative_to(folder))] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


@pytest.fixture()
def work(tmp_path: Path) -> Path:
    arr = np.full((100, 120), 255, np.uint8)
    arr[40:60, 50:70] = 0
    Image.fromarray(arr).save(tmp_path / "block.png")
    (tmp_path / "office.yaml").write_text("image: block.png\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n"
                                          "occupied_thresh: 0.65\nfree_thresh: 0.196\nnegate: 0\n")
    rows = ["." * 120] * 100
    (tmp_path / "arena.map").write_text("type octile\nheight 100\nwidth 120\nmap\n" + "\n".join(rows) + "\n")
    (tmp_path / "arena.map.scen").write_text("version 1\n0\tarena.map\t120\t100\t1\t1\t100\t90\t140.0\n")
    (tmp_path / "sub").mkdir()
    (tmp_path / "link.png").symlink_to("block.png")
    os.link(tmp_path / "block.png", tmp_path / "hard.png")
    return tmp_path


def refused(exe, cwd: Path, *args: str, needle: str = "") -> str:
    before = snapshot(cwd)
    r = run_cli(exe, *args, cwd=cwd, env={**os.environ, "NDRQL_CACHE": str(cwd / ".cache")})
    line = assert_one_line_error(r, needle)
    assert snapshot(cwd) == before, "a file was changed or added"
    return line


CLASHES = [
    ("plan", "block.png", *POINTS, "--json", "block.png"),
    ("plan", "block.png", *POINTS, "--png", "block.png"),
    ("plan", "block.png", *POINTS, "--json", "link.png"),
    ("plan", "block.png", *POINTS, "--json", "sub/../block.png"),
    ("plan", "block.png", *POINTS, "--json", "hard.png"),
    ("plan", "office.yaml", *POINTS, "--path-out", "office.yaml"),
    ("plan", "office.yaml", *POINTS, "--json", "block.png"),
    ("plan", "arena.map", "--scen", "arena.map.scen", "--json", "arena.map"),
    ("plan", "arena.map", "--scen", "arena.map.scen", "--png", "arena.map.scen"),
    ("plan", "arena.map", "--scen", "arena.map.scen", "--all", "--jsonl", "arena.map.scen"),
    ("plan", "block.png", *POINTS, "--weights", "hard.png", "--json", "block.png"),
    ("astar", "block.png", *POINTS, "--png", "link.png"),
    ("astar", "office.yaml", *POINTS, "--json", "block.png"),
    ("map", "convert", "office.yaml", "block.png"),
    ("map", "convert", "block.png", "sub/../link.png"),
    ("map", "info", "arena.map", "--json", "arena.map"),
]


@pytest.mark.parametrize("args", CLASHES, ids=[" ".join(a[1:]) for a in CLASHES])
def test_an_output_on_an_input_is_refused_and_nothing_changes(ndrql_exe, work, args):
    refused(ndrql_exe, work, *args, needle="nothing was written")


def test_weights_checkpoint_and_preset_are_inputs_too(ndrql_exe, work):
    (work / "w.pt").write_bytes(b"not really a checkpoint")
    (work / "p.json").write_text("{}")
    refused(ndrql_exe, work, "plan", "block.png", *POINTS, "--weights", "w.pt", "--json", "w.pt", needle="--weights")
    refused(ndrql_exe, work, "plan", "block.png", *POINTS, "--preset", "p.json", "--png", "p.json", needle="--preset")
    refused(ndrql_exe, work, "export-weights", "w.pt", "--out", "w.pt", needle="CHECKPOINT")
    (work / "region.png").write_bytes((work / "block.png").read_bytes())
    refused(ndrql_exe, work, "predict", "region.png", *POINTS, "--out", "sub/..", needle="named like the input")


def test_two_outputs_on_one_file_and_stdout_rules(ndrql_exe, work):
    refused(ndrql_exe, work, "astar", "block.png", *POINTS, "--json", "o.x", "--png", "o.x", needle="both write")
    refused(ndrql_exe, work, "astar", "block.png", *POINTS, "--png", "-", needle="standard output")
    refused(ndrql_exe, work, "plan", "block.png", *POINTS, "--path-out", "-", needle="standard output")


def test_a_legitimate_output_beside_the_input_is_written(ndrql_exe, work):
    r = run_cli(ndrql_exe, "astar", "block.png", *POINTS, "--json", "out.json", "--png", "out.png", cwd=work)
    assert r.returncode == 0, r.stderr
    assert json.loads((work / "out.json").read_text())["length"] > 0
    r = run_cli(ndrql_exe, "map", "convert", "office.yaml", "copy.png", cwd=work)
    assert r.returncode == 0, r.stderr


def test_guard_rules_directly(tmp_path):
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "a.png").write_bytes(b"x")
    (tmp_path / "m.png").write_bytes(b"x")
    ok = [Input("MAP", str(tmp_path / "m.png")), Input("--data", str(tmp_path / "data"), folder=True)]
    check_outputs([Output("--json", str(tmp_path / "data" / "new.json")), Output("--png", str(tmp_path / "o.png"))], ok)
    with pytest.raises(OutputError, match="file of the input folder"):
        check_outputs([Output("--json", str(tmp_path / "data" / "a.png"))], ok)
    with pytest.raises(OutputError, match="overlaps the input folder"):
        check_outputs([Output("--out", str(tmp_path / "data" / "deeper"), folder=True)], ok)
    with pytest.raises(OutputError, match="named like the input"):
        check_outputs([Output("--out", str(tmp_path), folder=True, names=("m.png",))], ok)
    check_outputs([Output("--out", str(tmp_path), folder=True, names=("region.png",))], ok[:1])
    with pytest.raises(OutputError, match="named like the input"):
        check_outputs([Output("--out", str(tmp_path), folder=True)], ok[:1])  # names unknown: nothing inside
    with pytest.raises(OutputError, match="both write"):
        check_outputs([Output("--out", str(tmp_path / "f"), folder=True, names=("r.png",)),
                       Output("--png", str(tmp_path / "f" / "r.png"))])
    with pytest.raises(OutputError, match="cannot both write"):
        check_outputs([Output("--json", "-", stdout=True), Output("--markdown", "-", stdout=True)])
    check_outputs([Output("--json", os.devnull), Output("--png", os.devnull)], [Input("MAP", os.devnull)])


# --- --jsonl: resumes only its own files ------------------------------------------------------------

KEY = {"map": "a.map", "seed": 0}


def test_jsonl_refuses_a_foreign_file_and_leaves_it(tmp_path):
    for text in ("just one note without newline", "one\ntwo\n", '{"scenario": 1}\n', "[1, 2]\n", "{" * 100_000):
        path = tmp_path / "notes.txt"
        path.write_text(text)
        with pytest.raises(Exception, match="not a batch log"):
            with BatchLog(path, "fmt/1", KEY, "scenario"):
                pass
        assert path.read_text() == text


def test_jsonl_resumes_its_own_file_drops_a_cut_line_and_reads_duplicates_once(tmp_path):
    path = tmp_path / "log.jsonl"
    with BatchLog(path, "fmt/1", KEY, "scenario") as log:
        assert log.done == {}
        log.append({**KEY, "scenario": 0})
        log.append({**KEY, "scenario": 1})
        log.append({**KEY, "scenario": 1, "again": True})
    with open(path, "a") as f:
        f.write('{"format": "fmt/1", "map": "a.m')
    with BatchLog(path, "fmt/1", KEY, "scenario") as log:
        assert sorted(log.done) == [0, 1] and "again" not in log.done[1]
    assert path.read_text().endswith("}\n")
    with pytest.raises(Exception, match="another run"):
        with BatchLog(path, "fmt/1", {"map": "a.map", "seed": 1}, "scenario"):
            pass


def test_jsonl_second_writer_is_locked_out(tmp_path):
    path = tmp_path / "log.jsonl"
    with BatchLog(path, "fmt/1", KEY, "scenario"):
        with pytest.raises(Exception, match="another ndrql batch"):
            with BatchLog(path, "fmt/1", KEY, "scenario"):
                pass


def test_jsonl_cli_cases(ndrql_exe, work):
    (work / "notes.txt").write_text("my notes, no trailing newline")
    scen = ("plan", "arena.map", "--scen", "arena.map.scen", "--all", "--method", "QL")
    refused(ndrql_exe, work, *scen, "--jsonl", "notes.txt", needle="not a batch log")
    refused(ndrql_exe, work, *scen, "--jsonl", "sub", needle="folder")
    r = run_cli(ndrql_exe, *scen, "--jsonl", "new/deeper/log.jsonl", cwd=work)
    assert r.returncode == 0, r.stderr
    assert json.loads((work / "new/deeper/log.jsonl").read_text())["format"] == "ndrql-plan-batch/1"
    r = run_cli(ndrql_exe, *scen, "--jsonl", os.devnull, cwd=work)
    assert r.returncode == 0, r.stderr
