"""``ndrql reproduce labels`` (ndrql.experiments.labels_check): the real console script on a tiny dataset."""

from __future__ import annotations

import json

import pytest

from ndrql.experiments.labels_check import sample_indices

from helpers.cli import assert_one_line_error, run_cli


def test_sample_indices_spread_over_the_split():
    assert sample_indices(None, 1200) == list(range(1200))
    assert sample_indices(5000, 10) == list(range(10))
    picked = sample_indices(8, 1200)
    assert picked[0] == 0 and picked[-1] == 1199 and len(picked) == 8
    assert {i // 300 for i in picked} == {0, 1, 2, 3}  # every category block


def test_cli_reproduce_labels_on_a_tiny_dataset(ndrql_exe, tiny_dataset, tmp_path):
    out = tmp_path / "labels"
    r = run_cli(ndrql_exe, "reproduce", "labels", "--data", str(tiny_dataset), "--out", str(out), "--no-progress")
    assert r.returncode == 0, r.stderr
    assert f"labels: wrote {out / 'labels.md'}" in r.stdout
    text = (out / "labels.md").read_text()
    # The tiny dataset's guidelines are not drawn like cv2.line, its regions are our dilation: the
    # report says so instead of claiming a match.
    assert "equals its `PATH [2PIXEL]` image in 0/4 samples" in text
    assert "equals its `PATH [30PIXEL]` image in 4/4" in text
    for needle in ("| all | 4 | 0 |", "dataset path (RRT* waypoints)", "sample_endpoints start-goal distance", "Why ours"):
        assert needle in text
    summary = json.loads((out / "summary.json").read_text())
    assert [s["index"] for s in summary["samples"]] == [0, 1, 2, 3]
    assert all(s["has_path"] and 0 <= s["region_f1"] <= 1 for s in summary["samples"])


@pytest.mark.parametrize("argv, message", [(["--limit", "0"], "--limit must be an integer in 1.."),
                                           (["--data", "/nonexistent/ds"], "dataset directory not found")])
def test_cli_reproduce_labels_bad_input(ndrql_exe, tmp_path, argv, message):
    r = run_cli(ndrql_exe, "reproduce", "labels", "--out", str(tmp_path / "o"), *argv)
    assert_one_line_error(r, message)
