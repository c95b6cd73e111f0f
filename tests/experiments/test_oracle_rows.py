"""The oracle row of the planning tables: its priors, task keys and fingerprints, the share by hand, and
``ndrql reproduce table3|scale`` end to end (with the oracle row, with ``--prior-from oracle``, at two grids)."""

from __future__ import annotations

import json
from dataclasses import asdict, replace

import numpy as np
import pytest

from ndrql.errors import NdrqlError
from ndrql.experiments import stats
from ndrql.experiments.digests import array_digest, fingerprint
from ndrql.experiments.planning_runs import (ORACLE_LABEL, TASK_VERSION, SweepOptions, make_tasks, method_fields,
                                             oracle_share)
from ndrql.experiments.report import share_table
from ndrql.maps.grid import area_downscale
from ndrql.maps.problem import MapProblem
from ndrql.pipeline.samples import OraclePriors, Problem
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import get_method
from ndrql.synth.oracle import oracle_prediction

from helpers.cli import assert_one_line_error, run_cli

ORACLE = "NDR-QL" + ORACLE_LABEL


def _problem() -> Problem:
    """A 16x16 grid with a wall and a gap on the right; the map is the grid at 4 px per cell."""
    b = np.zeros((16, 16), bool)
    b[8, :12] = True
    return Problem("synthetic", 0, "wall", MapProblem(np.kron(b, np.ones((4, 4), bool)), (2, 2), (62, 2)), b, (0, 0), (15, 0), 38)


class _ModelSource:
    """What make_tasks reads of a prediction cache."""

    prior_from = "model"
    digest = "0123456789abcdef"


def test_oracle_priors_are_the_grids_own_path_as_cell_means():
    p = _problem()
    a = OraclePriors().attach(p)
    region, guide = oracle_prediction(p.blocked, p.start, p.goal, 4)
    assert np.array_equal(a.region, area_downscale(region.astype(np.float64), p.blocked.shape))
    assert np.array_equal(a.guideline, area_downscale(guide.astype(np.float64), p.blocked.shape))
    # the path has to pass the gap at columns 12..15 of row 8: the guideline runs there, not through the wall
    assert a.guideline[8, 12:].max() > 0 and a.guideline[8, :12].max() == 0
    assert a.region[p.start] == a.region[p.goal] == 1.0
    region_map, guide_map = OraclePriors().full(p)
    assert region_map.shape == guide_map.shape == p.obstacles.shape
    assert OraclePriors().describe() == {"weights": "oracle priors", "prior_from": "oracle"}


def test_oracle_tasks_have_their_own_keys_and_fingerprints():
    p = _problem()
    opts = SweepOptions(seeds=2, progress=False)
    ql, ndr = get_method("QL"), get_method("NDR-QL")
    rng = np.random.default_rng(0)
    with_model = replace(p, region=rng.random(p.blocked.shape), guideline=rng.random(p.blocked.shape))
    oracle = OraclePriors()
    with_oracle = oracle.attach(p)
    qm, nm = make_tasks([with_model], [ql, ndr], opts, _ModelSource())
    qo, no = make_tasks([with_oracle], [ql, ndr], opts, oracle)
    assert (nm.key, no.key) == ("synthetic-0__NDR-QL", "synthetic-0__NDR-QL+oracle")
    assert (qm.key, qm.fingerprint) == (qo.key, qo.fingerprint)  # QL has no priors: one task for both
    assert nm.fingerprint != no.fingerprint
    # a model row's fingerprint is what it always was (the weights' digest), so stored tables are reused
    assert nm.fingerprint == fingerprint(TASK_VERSION, p.key, array_digest(p.blocked), p.start, p.goal,
                                         method_fields(ndr), [0, 1], asdict(QLConfig()), asdict(PriorConfig()),
                                         _ModelSource.digest, 0)
    # an oracle row's fingerprint follows the oracle's arrays
    halved = make_tasks([replace(with_oracle, guideline=with_oracle.guideline / 2)], [ndr], opts, oracle)[0]
    assert halved.key == no.key and halved.fingerprint != no.fingerprint


def _runs(*steps: int | tuple[int]) -> dict:
    """Stored runs with seeds 0, 1, ...; a 1-tuple is a run that did not converge (its total steps)."""
    return {"runs": [{"seed": i, "converged": not isinstance(s, tuple), "total_steps": s[0] if isinstance(s, tuple) else s + 7,
                      "convergence_steps": None if isinstance(s, tuple) else s} for i, s in enumerate(steps)]}


def test_share_is_pooled_over_the_same_maps_and_seeds_by_hand():
    results = {("a", "QL"): _runs(100, 300), ("a", "NDR-QL"): _runs(20, 40), ("a", ORACLE): _runs(10, 10),
               ("b", "QL"): _runs(200, (400,)), ("b", "NDR-QL"): _runs(50, 30), ("b", ORACLE): _runs(20, 20)}
    sh = oracle_share(results, ["a", "b"])
    # pooled: QL 100 + 300 + 200 + 400 (not converged: the steps it ran) = 1000, NDR-QL 140, oracle 60
    assert sh["maps"] == 2 and sh["steps"] == {"QL": 1000, "NDR-QL": 140, ORACLE: 60}
    assert sh["vs_ql"]["NDR-QL"] == pytest.approx(-0.86) and sh["vs_ql"][ORACLE] == pytest.approx(-0.94)
    assert sh["share"] == pytest.approx(0.86 / 0.94)
    assert oracle_share(results, ["a"])["share"] == pytest.approx((1 - 60 / 400) / (1 - 20 / 400))
    table = share_table({"all": sh}, "NDR-QL", ORACLE, seeds=2)
    assert "| all | 2 | 250 | 35 | 15 | -86.0% | -94.0% | 91% |" in table  # steps per run: 1000 / 4, ...
    results[("b", ORACLE)] = {"runs": [dict(r, seed=r["seed"] + 5) for r in results[("b", ORACLE)]["runs"]]}
    with pytest.raises(NdrqlError, match="different seeds"):
        oracle_share(results, ["a", "b"])


def test_share_of_oracle_is_nan_when_the_oracle_gains_nothing():
    assert stats.share_of_oracle([50], [25], [100]) == pytest.approx(0.5 / 0.75)
    assert stats.share_of_oracle([10, 20], [5, 5], [100, 100]) == pytest.approx(0.85 / 0.95)
    assert np.isnan(stats.share_of_oracle([50], [100], [100])) and np.isnan(stats.share_of_oracle([50], [120], [100]))
    assert stats.run_steps({"converged": False, "convergence_steps": None, "total_steps": 9}) == 9


def test_cli_prior_from_bad_combinations(ndrql_exe):
    r = run_cli(ndrql_exe, "reproduce", "table2", "--prior-from", "oracle")
    assert_one_line_error(r, "--prior-from oracle applies to table3 and scale, not table2")
    r = run_cli(ndrql_exe, "reproduce", "table3", "--prior-from", "oracle", "--weights", "paper")
    assert_one_line_error(r, "give either --weights or --prior-from oracle, not both")
    r = run_cli(ndrql_exe, "reproduce", "scale", "--prior-from", "model", "--grids", "5")
    assert_one_line_error(r, "grid sizes must be 8..256")
    r = run_cli(ndrql_exe, "reproduce", "table3", "--prior-from", "map")
    assert_one_line_error(r, "invalid choice")


def _fast(*extra: object) -> list[object]:
    """Flags that keep a table small: one worker, few episodes, the paper's constants, no progress bars."""
    return ["--workers", "1", "--max-episodes", "150", "--preset", "spec", "--no-progress", *extra]


def _steps_by_row(tasks_dir) -> dict[str, dict[str, list[int]]]:
    """Per task row (``QL``, ``NDR-QL``, ``NDR-QL+oracle``, ...) and map: the stored runs' steps, by seed order."""
    out: dict[str, dict[str, list[int]]] = {}
    for f in sorted(tasks_dir.glob("*.json")):
        key, row = json.loads(f.read_text())["key"].split("__")
        runs = json.loads(f.read_text())["result"]["runs"]
        assert [r["seed"] for r in runs] == [0, 1]
        out.setdefault(row, {})[key] = [stats.run_steps(r) for r in runs]
    return out


@pytest.mark.data
@pytest.mark.slow
def test_reproduce_scale_oracle_row_and_share_from_the_stored_runs(ndrql_exe, dataset_root, tmp_path):
    """scale with the paper model: the oracle row and the share per group, recomputed by hand from the task
    files (the same maps and seeds); then --prior-from oracle at grids 50 and 64, whose NDR-QL runs at 50 are
    exactly the oracle row's."""
    out = tmp_path / "results" / "scale"
    r = run_cli(ndrql_exe, "reproduce", "scale", "--data", dataset_root, "--per-category", "1", "--seeds", "2",
                "--out", out, *_fast())
    assert r.returncode == 0, r.stderr[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["prior_from"] == "model" and summary["grid"] == 50 and summary["weights"]["weights"].endswith(".pt")
    assert ORACLE in summary["groups"]["all"] and ORACLE in summary["groups"]["unseen/BUGTRAP"]
    steps = _steps_by_row(out / "tasks")
    assert set(steps) == {"QL", "O-QL", "IQL", "NDR-QL", "NDR-QL+oracle"} and len(steps["QL"]) == 8
    pooled = {row: sum(sum(v) for v in steps[row].values()) for row in ("QL", "NDR-QL", "NDR-QL+oracle")}
    by_hand = (1 - pooled["NDR-QL"] / pooled["QL"]) / (1 - pooled["NDR-QL+oracle"] / pooled["QL"])
    assert summary["oracle_share"]["NDR-QL"]["all"]["share"] == pytest.approx(by_hand, rel=1e-12)
    assert summary["oracle_share"]["NDR-QL"]["all"]["steps"]["QL"] == pooled["QL"]
    seen = [k for k in steps["QL"] if k.startswith("seen")]
    assert summary["oracle_share"]["NDR-QL"]["seen"]["steps"][ORACLE] == sum(sum(steps["NDR-QL+oracle"][k]) for k in seen)
    text = (out / "scale.md").read_text()
    assert "| all | NDR-QL (oracle priors) |" in text and "## Share of the oracle's reduction" in text

    oracle_out = tmp_path / "results" / "scale-oracle"
    r = run_cli(ndrql_exe, "reproduce", "scale", "--data", dataset_root, "--per-category", "1", "--seeds", "2",
                "--prior-from", "oracle", "--grids", "50,64", "--out", oracle_out, *_fast())
    assert r.returncode == 0, r.stderr[-3000:]
    for d, n in ((oracle_out, 50), (tmp_path / "results" / "scale-oracle-g64", 64)):
        s = json.loads((d / "summary.json").read_text())
        assert s["prior_from"] == "oracle" and s["grid"] == n and "oracle_share" not in s
        assert s["weights"] == {"weights": "oracle priors", "prior_from": "oracle"}
        assert "NDR priors: **oracle priors**" in (d / "scale.md").read_text()
    assert "Planning grid: 64x64" in (tmp_path / "results" / "scale-oracle-g64" / "scale.md").read_text()
    # the oracle table's NDR-QL tasks are the model table's oracle row: same key, fingerprint and runs
    for f in sorted((oracle_out / "tasks").glob("*+oracle.json")):
        mine, theirs = json.loads(f.read_text()), json.loads((out / "tasks" / f.name).read_text())
        assert mine["fingerprint"] == theirs["fingerprint"]
        assert [stats.run_steps(x) for x in mine["result"]["runs"]] == [stats.run_steps(x) for x in theirs["result"]["runs"]]


@pytest.mark.data
@pytest.mark.slow
def test_reproduce_table3_prior_from_oracle_names_the_oracle(ndrql_exe, dataset_root, tmp_path):
    r = run_cli(ndrql_exe, "reproduce", "table3", "--data", dataset_root, "--seeds", "1", *_fast(), cwd=tmp_path)
    # no --out: --prior-from oracle defaults to results/table3-oracle; here the model's table runs first
    assert r.returncode == 0, r.stderr[-3000:]
    model = json.loads((tmp_path / "results" / "table3" / "summary.json").read_text())
    assert set(model["oracle_share"]["NDR-QL"]) == {f"MAP-{i}" for i in range(1, 9)} | {"pooled"}
    r = run_cli(ndrql_exe, "reproduce", "table3", "--data", dataset_root, "--seeds", "1", "--prior-from", "oracle",
                *_fast(), cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    d = tmp_path / "results" / "table3-oracle"
    summary = json.loads((d / "summary.json").read_text())
    assert summary["weights"] == {"weights": "oracle priors", "prior_from": "oracle"} and summary["prior_from"] == "oracle"
    assert "oracle_share" not in summary and not any(k.endswith(ORACLE_LABEL) for k in summary["cells"])
    text = (d / "table3.md").read_text()
    assert "NDR priors: **oracle priors**" in text and "NDR weights" not in text
    assert sorted(f.name for f in (d / "tasks").glob("*NDR-QL*")) == sorted(
        f"{k}__NDR-QL+oracle.json" for k in ("seen-1", "seen-300", "seen-609", "seen-901", "unseen-1", "unseen-307",
                                             "unseen-601", "unseen-900"))
    # the oracle table's NDR-QL cells are the model table's oracle row
    for k in ("seen-1", "unseen-900"):
        assert summary["cells"][f"{k}|NDR-QL"]["steps"] == model["cells"][f"{k}|{ORACLE}"]["steps"]
