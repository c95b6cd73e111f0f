"""The release report on a tiny sealed-like set: the seal is checked, every run is counted in the ledger
before the maps are read, a dirty tree and development sets are refused."""

from __future__ import annotations

import json
import subprocess

import pytest

from ndrql.errors import NdrqlError
from ndrql.experiments import eval_sets, release as rel
from ndrql.experiments.eval_sets import parse_registry, set_record
from ndrql.planning.preset import load_preset
from tests.helpers.cli import assert_one_line_error, run_cli

TINY = {"sets": {
    "dev-tiny": {"role": "development", "families": ["blocks", "maze"], "sizes": [96], "count": 4, "seed": 900_901},
    "sealed-tiny": {"role": "sealed", "families": ["blocks", "maze"], "sizes": [96], "count": 4, "seed": 950_901},
}}


@pytest.fixture()
def tiny(monkeypatch, tmp_path):
    """A registry with one tiny sealed set whose digests are recorded (in a private cache)."""
    monkeypatch.setenv("NDRQL_CACHE", str(tmp_path / "cache"))
    sets = parse_registry(TINY)
    monkeypatch.setattr(eval_sets, "registry", lambda: sets)
    monkeypatch.setattr(rel, "registry", lambda: sets)
    gs = eval_sets.eval_set(sets["sealed-tiny"].spec, progress=False, release=True)
    digests = {"sets": {"sealed-tiny": {"role": "sealed", **set_record(gs)}}, "training": {}}
    monkeypatch.setattr(eval_sets, "recorded_digests", lambda: digests)
    return digests


def test_development_sets_and_unknown_sets_are_refused(tiny):
    with pytest.raises(NdrqlError, match="'dev-tiny' is a development set"):
        rel.check_sealed_names(["dev-tiny"])
    with pytest.raises(NdrqlError, match="unknown evaluation set 'nope'; sealed sets: sealed-tiny"):
        rel.check_sealed_names(["nope"])


def test_a_dirty_tree_is_refused_and_nothing_is_counted(tiny, tmp_path):
    repo = tmp_path / "repo"
    repo.mkdir()
    git = ["git", "-C", str(repo), "-c", "user.email=t@t", "-c", "user.name=t"]
    subprocess.run([*git, "init", "-q"], check=True)
    (repo / "a.txt").write_text("a")
    subprocess.run([*git, "add", "a.txt"], check=True)
    subprocess.run([*git, "commit", "-qm", "a"], check=True)
    sha, dirty = rel.git_commit(repo)
    assert len(sha) == 40 and not dirty
    (repo / "a.txt").write_text("b")
    assert rel.git_commit(repo) == (sha, True)
    (repo / "docs").mkdir()
    ledger = repo / "docs" / "ledger.json"
    with pytest.raises(NdrqlError, match="uncommitted changes"):
        rel.release(tmp_path / "out", ["sealed-tiny"], ledger=ledger, repo=repo)
    assert not ledger.exists() and not (tmp_path / "out").exists()
    assert rel.git_commit(tmp_path / "nowhere") == ("unknown", False)


def test_a_set_that_does_not_match_its_seal_is_refused_before_it_is_counted(tiny, tmp_path):
    tiny["sets"]["sealed-tiny"]["maps"][0] = "0" * 16
    ledger = tmp_path / "ledger.json"
    with pytest.raises(NdrqlError, match="does not match its recorded digests"):
        rel.release(tmp_path / "out", ["sealed-tiny"], ledger=ledger, repo=tmp_path)
    assert not ledger.exists()


@pytest.mark.slow
def test_the_release_report_counts_every_run(tiny, tmp_path, model_weights):
    ledger = tmp_path / "ledger.json"
    kw = dict(ledger=ledger, repo=tmp_path, weights=str(model_weights), preset=load_preset("general"), grids=(32,),
              seeds=2, workers=1, executor="serial", progress=False, log=lambda m: None)
    first = rel.release(tmp_path / "out", ["sealed-tiny"], command="ndrql reproduce release", **kw)
    text = first[0].read_text()
    assert first[0].name == "release.md" and "sealed set 'sealed-tiny'" in text
    assert "This set has been evaluated 1 time (" in text and "this is run 1, commit unknown" in text
    assert "| IQL (BFS distance) |" in text and "| QL (tuned) |" in text and "clear wins / ties / losses" in text
    book = json.loads(ledger.read_text())
    assert [r["run"] for r in book["runs"]] == [1] and book["runs"][0]["finished"]
    assert book["runs"][0]["reports"]["sealed-tiny"]["sha256"] and book["runs"][0]["command"] == "ndrql reproduce release"
    second = rel.release(tmp_path / "out2", ["sealed-tiny"], **kw)
    assert "evaluated 2 times" in second[0].read_text() and "this is run 2" in second[0].read_text()
    assert rel.times_evaluated(json.loads(ledger.read_text()), "sealed-tiny") == 2


def test_the_cli_refuses_a_development_set_and_a_missing_ledger_folder(ndrql_exe, tmp_path):
    r = run_cli(ndrql_exe, "reproduce", "release", "--eval-set", "transfer", "--out", tmp_path / "o", cwd=tmp_path)
    assert_one_line_error(r, "'transfer' is a development set")
    r = run_cli(ndrql_exe, "reproduce", "release", "--ledger", tmp_path / "none" / "l.json", "--out", tmp_path / "o",
                cwd=tmp_path)
    assert_one_line_error(r, "its folder does not exist")
    assert not (tmp_path / "o").exists()


def test_an_unreadable_ledger_is_refused(tmp_path):
    bad = tmp_path / "l.json"
    bad.write_text("{")
    with pytest.raises(NdrqlError, match="unreadable release ledger"):
        rel.read_ledger(bad)
    bad.write_text('{"format": "other"}')
    with pytest.raises(NdrqlError, match="is not a release ledger"):
        rel.read_ledger(bad)
    assert rel.read_ledger(tmp_path / "new.json")["runs"] == []


def test_a_release_without_sets_reads_sealed_only_and_each_large_set_at_its_own_grid():
    from ndrql.experiments.eval_sets import registry
    from ndrql.experiments.release import default_release

    assert default_release(None, None) == (["sealed"], (50, 100))
    assert default_release(["sealed-large-256"], None) == (["sealed-large-256"], (256,))
    assert default_release(["sealed-large-128"], None) == (["sealed-large-128"], (128,))
    assert default_release(["sealed-large-128"], (64,)) == (["sealed-large-128"], (64,))
    sets = registry()
    assert sets["sealed"].grids == sets["transfer"].grids == (50, 100) and sets["large-dev-256"].grids == (256,)
    with pytest.raises(NdrqlError, match="one at a time"):
        default_release(["sealed", "sealed-large-256"], None)
