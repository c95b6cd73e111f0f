"""studies/partial: the headroom and sensing studies run end to end on a few maps of the development set."""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "partial"))

import headroom  # noqa: E402
import sense  # noqa: E402


def test_headroom_rows_and_report(tmp_path, capsys):
    out = tmp_path / "h.jsonl"
    assert headroom.main(["--grids", "50", "--limit", "4", "--seeds", "2", "--out", str(out)]) == 0
    recs = [json.loads(x) for x in out.read_text().splitlines()]
    assert len(recs) == 4 and {r["index"] for r in recs} == {0, 1, 2, 3}
    ran = [r for r in recs if "rows" in r]
    assert ran and all(set(r["rows"]) == set(headroom.ROWS) for r in ran)
    assert all(abs(r["unknown_share"] - 0.3) < 0.01 for r in recs)
    assert headroom.main(["--grids", "50", "--limit", "4", "--seeds", "2", "--out", str(out)]) == 0  # resumes: nothing new
    assert len(out.read_text().splitlines()) == 4
    assert headroom.main(["--report", str(out)]) == 0
    assert "headroom of the oracle over IQL-BFS (belief)" in capsys.readouterr().out


def test_sense_rows_and_report(tmp_path, capsys):
    out = tmp_path / "s.jsonl"
    assert sense.main(["--grids", "50", "--limit", "3", "--seeds", "1", "--every", "1,5", "--out", str(out)]) == 0
    ran = [json.loads(x) for x in out.read_text().splitlines() if "rows" in json.loads(x)]
    assert ran and all(set(r["rows"]) == {"static", "truth", "every 1", "every 5"} for r in ran)
    assert sense.main(["--report", str(out)]) == 0
    assert "| every 1 |" in capsys.readouterr().out
