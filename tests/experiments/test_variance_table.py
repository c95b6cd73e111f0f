"""tools/variance_table.py: the variance-over-training tables, by hand on small reports."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

TOOL = Path(__file__).resolve().parents[2] / "tools" / "variance_table.py"


def _tool():
    spec = importlib.util.spec_from_file_location("variance_table", TOOL)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _row(steps: list[int]) -> dict:
    return {"steps": steps, "converged": [True] * len(steps), "ratio": [1.0] * len(steps), "threshold": 0.9}


def _record(key: str, family: str, iql: int, ndr: int, oracle: int) -> dict:
    return {"key": key, "family": family, "n": 50, "size": 50, "skipped": False, "f1": (0.8, 0.5),
            "judged_threshold": 0.9,
            "runs": {"IQL": _row([iql, iql]), "NDR-QL (model)": _row([ndr, ndr]), "NDR-QL (oracle)": _row([oracle, oracle])}}


def _report(root: Path, name: str, ndr: tuple[int, int]) -> None:
    """A report of two maps (maze, rooms) with IQL 400 steps and the oracle 100, NDR-QL as given."""
    folder = root / f"{name}-general"
    folder.mkdir(parents=True)
    records = [_record("a", "maze", 400, ndr[0], 100), _record("b", "rooms", 400, ndr[1], 100)]
    (folder / "summary.json").write_text(json.dumps({"preset": "general", "grids": [50], "records": records}))


def test_the_tables_by_hand(tmp_path, capsys):
    _report(tmp_path, "var-s0", (200, 100))   # ratios 0.5, 0.25 -> geomean sqrt(0.125)
    _report(tmp_path, "var-s1", (100, 100))   # 0.25, 0.25 -> 0.25
    _report(tmp_path, "var-no-maze", (400, 100))  # maze left out: 1.0 against s0's 0.5
    assert _tool().main([str(tmp_path)]) == 0
    out = capsys.readouterr().out
    g0 = 0.125 ** 0.5
    assert f"| var-s0 | 2 | {g0:.3f} " in out and "| var-s1 | 2 | 0.250 (0.250-0.250) |" in out
    # over the two seeds: min, max, mean and sample standard deviation of the two ratios
    sd = abs(g0 - 0.25) / 2 ** 0.5
    assert f"NDR-QL / IQL 0.250-{g0:.3f} (mean {(g0 + 0.25) / 2:.3f}, sd {sd:.3f})" in out
    # share of the oracle's gain: (1 - 0.25) / (1 - 0.25) for s1
    assert "| var-s1 | 2 | 0.250 (0.250-0.250) | 2 / 0 / 0 | 100% |" in out
    # the leave-out run against seed 0, on the family it left out, and the rest
    assert "| maze | 0.500 | 1.000 | 2.00 |" in out
    assert "The other 1 family: 1.00x the seed-0 run's ratio" in out


def test_an_empty_folder_is_one_clear_error(tmp_path, capsys):
    assert _tool().main([str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("variance_table: error: no var-*")


@pytest.mark.parametrize(("name", "families"), [("var-no-maze", ["maze"]),
                                                ("var-no-maze-warehouse-corridor_maze", ["maze", "warehouse", "corridor_maze"])])
def test_left_out_families_are_read_from_the_run_name(name, families):
    assert _tool().left_out(name, "var") == families
