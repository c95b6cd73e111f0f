"""``ndrql reproduce partial`` (issue 54): belief maps through plan's own request, the report, its figure, the ledger."""

from __future__ import annotations

import json
import subprocess

import pytest

from ndrql.api import run_request
from ndrql.errors import NdrqlError
from ndrql.experiments import eval_sets, release as rel
from ndrql.experiments.eval_sets import eval_set, eval_spec, parse_registry, set_record
from ndrql.experiments.partial import (REF, BeliefSetting, one_case, parse_beliefs, parse_sense, plain_priors,
                                       run_rows)
from ndrql.experiments.partial_run import FIGURE, RECORDS, partial
from ndrql.planning.preset import load_preset

from helpers.belief_model import warm_belief_checkpoint
from helpers.cli import run_main

pytest.importorskip("torch")


@pytest.fixture(scope="module")
def belief_file(tmp_path_factory):
    return warm_belief_checkpoint(tmp_path_factory.mktemp("belief") / "belief.pt")


def test_settings_parse_and_bad_ones_are_one_clear_line():
    assert [s.label for s in parse_beliefs("blobs:0.1, sensed,outdated,blobs")] == ["blobs:0.1", "sensed", "outdated",
                                                                                    "blobs:0.3"]
    assert parse_sense("off,on") == (False, True) and parse_sense("on") == (True,)
    for bad, what in (("cloud", "unknown kind"), ("blobs:2", r"\(0, 0.9\]"), ("sensed:0.2", "takes no fraction"),
                      ("", "empty")):
        with pytest.raises(NdrqlError, match=what):
            parse_beliefs(bad)
    with pytest.raises(NdrqlError, match="off, on"):
        parse_sense("maybe")


@pytest.mark.parametrize(("args", "message"), [
    (["--beliefs", "blobs:2"], "blobs:FRACTION"),
    (["--sense", "sometimes"], "--sense takes off, on"),
    (["--rows", "IQL"], "--rows does not apply to partial"),
    (["--alpha", "0.5"], "--alpha does not apply"),
    (["--eval-set", "nope"], "unknown evaluation set 'nope'"),
])
def test_bad_options_exit_2_with_one_line(tmp_path, args, message):
    out = run_main(["reproduce", "partial", "--out", str(tmp_path / "o"), "--no-progress", *args])
    assert out.returncode == 2, out.stderr
    assert out.stderr.count("\n") == 1 and out.stderr.startswith("ndrql: error: ") and message in out.stderr
    assert not (tmp_path / "o").exists()


def test_three_maps_of_partial_dev_through_plans_request(tmp_path, belief_file):
    """NDR-QL is what ``plan --hide`` runs (the record says which source served); the reference equals IQL-BFS built
    on the belief's grid directly; the report leads with the oracle's headroom and judges the floors; a re-run
    resumes without running anything."""
    logs: list[str] = []
    kw = dict(runner=run_request, set_name="partial-dev", grids=(50,), beliefs="blobs:0.3", senses=(False,), seeds=1, limit=3,
              weights=str(belief_file), workers=1, executor="serial", progress=False, log=logs.append)
    path = partial(tmp_path / "out", **kw)
    text = path.read_text()
    assert text.index("**headroom**") < text.index("**NDR-QL / IQL-BFS (belief)**")
    assert "## The floors of issue 54" in text and text.count("**PASS**") + text.count("**MISS**") == 3
    assert "path quality" in text and "median / p95 / max" in text
    assert (tmp_path / "out" / FIGURE).stat().st_size > 10_000
    recs = [json.loads(x) for x in (tmp_path / "out" / RECORDS).read_text().splitlines()]
    belief = [r for r in recs if r["belief"] == "blobs:0.3" and "rows" in r]
    assert belief and all(r["ndr"]["served"] == "model" and r["ndr"]["weights"] == str(belief_file) for r in belief)
    gs = eval_set(eval_spec("partial-dev"), False)
    preset = load_preset("general")
    for r in belief:
        pc = one_case(gs, r["index"], 50, BeliefSetting("blobs", 0.3))
        direct = run_rows(pc.case, {REF: ("IQL-BFS", plain_priors("IQL-BFS", pc.bcase, preset), 0.0)}, preset, [0])
        assert r["rows"][REF]["steps"] == direct["rows"][REF]["steps"]
        assert r["rows"]["NDR-QL (model)"]["steps"] == r["rows"]["NDR-QL"]["steps"]  # the judge accepted the model
        # IQL-NDR through the same request: Eq. 5 on the model's distance (floored at the belief's BFS distance)
        assert r["iql_ndr"] == {"served": "model", "qi_distance": "model", "fallback": None}
        assert len(r["rows"]["IQL-NDR"]["steps"]) == 1
    assert "**IQL-NDR / IQL-BFS (belief)**" in text and "(not judged by the floors)" in text
    partial(tmp_path / "out", **kw)
    assert "running 0" in logs[-1] or any("running 0" in m for m in logs[-3:])


TINY = {"sets": {"sealed-tiny": {"role": "sealed", "families": ["blocks", "maze"], "sizes": [96], "count": 3,
                                 "seed": 950_902}}}


@pytest.fixture()
def sealed_tiny(monkeypatch, tmp_path):
    """A registry with one tiny sealed set whose digests are recorded (in a private cache), and a git checkout."""
    monkeypatch.setenv("NDRQL_CACHE", str(tmp_path / "cache"))
    sets = parse_registry(TINY)
    monkeypatch.setattr(eval_sets, "registry", lambda: sets)
    gs = eval_sets.eval_set(sets["sealed-tiny"].spec, progress=False, release=True)
    digests = {"sets": {"sealed-tiny": {"role": "sealed", **set_record(gs)}}, "training": {}}
    monkeypatch.setattr(eval_sets, "recorded_digests", lambda: digests)
    repo = tmp_path / "repo"
    (repo / "docs").mkdir(parents=True)
    git = ["git", "-C", str(repo), "-c", "user.email=t@t", "-c", "user.name=t"]
    subprocess.run([*git, "init", "-q"], check=True)
    (repo / "a.txt").write_text("a")
    subprocess.run([*git, "add", "a.txt"], check=True)
    subprocess.run([*git, "commit", "-qm", "a"], check=True)
    return repo


def test_a_sealed_set_is_refused_on_a_dirty_tree_and_counted_in_the_ledger(sealed_tiny, tmp_path, belief_file):
    repo, ledger = sealed_tiny, sealed_tiny / "docs" / "ledger.json"
    kw = dict(runner=run_request, set_name="sealed-tiny", grids=(32,), beliefs="blobs:0.3", senses=(False,), seeds=1, ledger=ledger,
              repo=repo, weights=str(belief_file), workers=1, executor="serial", progress=False, figure=False,
              log=lambda m: None)
    with pytest.raises(NdrqlError, match="--limit does not apply to a sealed set"):
        partial(tmp_path / "out", limit=2, **kw)
    (repo / "a.txt").write_text("b")
    with pytest.raises(NdrqlError, match="uncommitted changes"):
        partial(tmp_path / "out", **kw)
    assert not ledger.exists() and not (tmp_path / "out").exists()
    (repo / "a.txt").write_text("a")
    text = partial(tmp_path / "out", **kw).read_text()
    book = json.loads(ledger.read_text())
    run = book["runs"][0]
    assert run["target"] == "partial" and run["sets"] == ["sealed-tiny"] and run["finished"]
    assert run["reports"]["sealed-tiny"]["path"].endswith("partial.md")
    assert "Ledger" in text and "run 1" in text and "read of sealed-tiny 1 at this size" in text
    assert rel.attempt_line(book, 32, 1, "sealed-tiny").startswith("- grid 32: read of sealed-tiny 1")
    recs = [json.loads(x) for x in (tmp_path / "out" / RECORDS).read_text().splitlines()]
    assert any("NDR-QL" in r.get("rows", {}) for r in recs), recs


def _records(ref: float, ndr: float, oracle: float, maps: int = 4) -> list[dict]:
    """Synthetic records of ``maps`` maps (truth and belief records), three seeds each, with these mean steps."""
    out = []
    for i in range(maps):
        seeds = lambda m: [m - 1.0, m, m + 1.0]  # noqa: E731
        out.append({"index": i, "grid": 50, "belief": None, "rows": {"IQL": {"steps": seeds(ref), "ratio": [1.0] * 3},
                                                                     "NDR-QL (oracle)": {"steps": seeds(oracle),
                                                                                         "ratio": [1.0] * 3}}})
        out.append({"index": i, "grid": 50, "belief": "blobs:0.3", "sense": False, "family": f"f{i % 2}",
                    "unknown_share": 0.3, "rows": {REF: {"steps": seeds(ref), "ratio": [1.0] * 3},
                                                   "NDR-QL": {"steps": seeds(ndr), "ratio": [1.0] * 3, "seconds": 0.1}}})
    return out


def test_the_floors_are_judged_on_geometric_means_and_the_oracles_share():
    from ndrql.experiments.partial_report import floors, group_summary, joined, report_text

    ok = group_summary(joined(_records(1000, 790, 500)))
    assert ok["ndr"]["ratio"] == pytest.approx(0.79) and ok["headroom"] == pytest.approx(0.5)
    assert ok["share"] == pytest.approx(0.42) and ok["ndr_outcomes"]["wins"] == 4
    assert [line.count("**PASS**") for line in floors(ok)] == [1, 1, 1]
    miss = floors(group_summary(joined(_records(1000, 1100, 500))))
    assert [line.count("**MISS**") for line in miss] == [1, 1, 1]
    flat = floors(group_summary(joined(_records(1000, 1000, 950))))
    assert len(flat) == 1 and "under 15%" in flat[0]
    tiny = report_text(_records(1000, 1060, 998), "# r\n", (50,), ["blobs:0.3"], (False,))  # 0.2% headroom
    assert "share of the oracle's gain not given (the oracle's headroom 0.2% is under 15%)" in tiny
    assert "%;" not in tiny.split("share of the oracle's gain")[1].split("\n")[0]  # no -3,000% share
    text = report_text(_records(1000, 790, 500), "# r\n", (50,), ["blobs:0.3"], (False,))
    assert text.count("**PASS**") == 3 and "| **all** | 4 | 1.00 | 0.79 | 0.50 | 1,000 |" in text


def test_iql_ndr_is_reported_beside_ndr_ql_and_not_judged():
    from ndrql.experiments.partial_report import floors, group_summary, joined, report_text

    recs = _records(1000, 790, 500)
    for r in recs:
        if r["belief"]:
            r["rows"]["IQL-NDR"] = {"steps": [849.0, 850.0, 851.0], "ratio": [1.0] * 3}
    s = group_summary(joined(recs))
    q = s["iql_ndr"]
    assert q["maps"] == 4 and q["ratio"] == pytest.approx(0.85) and q["share"] == pytest.approx(0.30)
    assert q["outcomes"]["wins"] == 4 and s["ndr"]["ratio"] == pytest.approx(0.79)  # NDR-QL's figures unchanged
    assert floors(s) == floors(group_summary(joined(_records(1000, 790, 500))))  # the floors judge NDR-QL only
    text = report_text(recs, "# r\n", (50,), ["blobs:0.3"], (False,))
    assert "**IQL-NDR / IQL-BFS (belief)** (4 maps): **0.850**" in text and "share of the oracle's gain 30%" in text
    assert "| **all** | 4 | 1.00 | 0.79 | 0.85 | 0.50 | 1,000 |" in text
