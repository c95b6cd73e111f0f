"""Experiment pieces: warm starts through run_plan(keep_q=True), Table 2 variants, plots, the fixed
maps' selection rule, and the reproduce CLI (bad input; a real table on the dataset)."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from ndrql.experiments.scale import scale_refs
from ndrql.experiments.table2 import TABLE2_ROWS
from ndrql.planning.config import PriorConfig
from ndrql.planning.methods import Priors, build_priors
from ndrql.planning.runner import run_plan

from helpers.cli import assert_one_line_error, run_cli


def _grid():
    b = np.zeros((20, 20), bool)
    b[10, :15] = True
    return b, (0, 0), (19, 0)


def test_keep_q_returns_final_table_and_warm_start_reconverges_fast():
    b, s, g = _grid()
    cold = run_plan(b, s, g, "QL", seed=3, keep_q=True)
    assert cold.converged and cold.q_table.shape == (400, 4)
    assert "q_table" not in cold.to_dict() and "q_table" not in cold.to_json()
    pri = build_priors("QL", b, s, g)
    warm = run_plan(b, s, g, "QL", seed=3, priors=Priors(pri.r_c, cold.q_table, None))
    assert warm.converged
    # a converged table is already stable: the greedy path holds for W episodes straight away
    assert warm.convergence_episode <= 2 * 20 < cold.convergence_episode
    assert warm.convergence_steps < cold.convergence_steps / 5
    # keep_q does not change the run itself
    assert run_plan(b, s, g, "QL", seed=3).same_run(cold)


def test_table2_rows_compose_as_the_registry():
    b, s, g = _grid()
    rng = np.random.default_rng(0)
    region, guide = rng.random(b.shape), rng.random(b.shape)
    cfg = PriorConfig()
    by = {m.name: m for m in TABLE2_ROWS}
    for name in ("D-C", "N-C", "D-Q", "NDR-QL"):
        a = build_priors(by[name], b, s, g, region, guide, cfg)
        ref = build_priors(name, b, s, g, region, guide, cfg)
        assert np.array_equal(a.r_c, ref.r_c) and np.array_equal(a.q0, ref.q0)
    # D-Q + N-Q is Eq. 6 (the registry's N-Q); N-Q alone is its mask term only
    eq6 = build_priors("N-Q", b, s, g, region, guide, cfg)
    assert np.array_equal(build_priors(by["D-Q+N-Q"], b, s, g, region, guide, cfg).q0, eq6.q0)
    mask_only = build_priors(by["N-Q"], b, s, g, region, guide, cfg)
    assert mask_only.threshold == eq6.threshold
    dq = build_priors("D-Q", b, s, g).q0
    np.testing.assert_allclose(mask_only.q0 + (1 - cfg.omega_qi) * dq, eq6.q0, atol=1e-12)
    assert set(np.unique(mask_only.q0)) <= {0.0, cfg.omega_qi * cfg.mask_low}


def test_scale_refs_are_stratified():
    refs = scale_refs(50)
    assert len(refs) == 400 and len(set(refs)) == 400
    for split in ("seen", "unseen"):
        blocks = [i // 300 for sp, i in refs if sp == split]
        assert [blocks.count(k) for k in range(4)] == [50, 50, 50, 50]
    with pytest.raises(ValueError):
        scale_refs(0)


@pytest.mark.data
def test_table3_maps_follow_their_rule(dataset_root):
    """maps_table3.json: first sample per category with A* >= 80 on the connected planning grid."""
    from ndrql.errors import NoPathError
    from ndrql.experiments.problems import table3_maps
    from ndrql.pipeline.samples import load_problem

    spec = json.loads(__import__("importlib.resources").resources.files("ndrql.experiments")
                      .joinpath("maps_table3.json").read_text())
    assert [m["label"] for m in spec["maps"]] == [f"MAP-{i}" for i in range(1, 9)]
    for ref, m in zip(table3_maps(), spec["maps"]):
        block = ref.index // 300
        for i in range(block * 300, ref.index):  # every earlier sample of the category fails the rule
            try:
                assert load_problem(dataset_root, ref.split, i).astar < 80
            except NoPathError:
                pass
        p = load_problem(dataset_root, ref.split, ref.index)
        assert p.astar == m["astar"] >= 80 and p.category == m["category"]


def test_cli_reproduce_bad_input(ndrql_exe):
    r = run_cli(ndrql_exe, "reproduce", "table9")
    assert_one_line_error(r, "invalid choice")
    r = run_cli(ndrql_exe, "reproduce", "table3", "--seeds", "0")
    assert r.returncode == 2 and r.stderr.strip() == "ndrql: error: --seeds must be an integer in 1..10,000, got 0"
    r = run_cli(ndrql_exe, "reproduce", "table3", "--data", "/nonexistent")
    assert_one_line_error(r, "pass --data DIR")
    r = run_cli(ndrql_exe, "reproduce", "--help")
    assert r.returncode == 0 and "ndrql reproduce table3" in r.stdout


@pytest.mark.data
@pytest.mark.slow
def test_cli_reproduce_table3_without_model(ndrql_exe, dataset_root, tmp_path):
    """Without NDR weights the N-* rows cannot run: one line on stderr naming NDRQL_WEIGHTS, exit 2."""
    env = dict(__import__("os").environ, NDRQL_WEIGHTS=str(tmp_path / "missing.pt"))
    r = run_cli(ndrql_exe, "reproduce", "table3", "--data", str(dataset_root), "--out", str(tmp_path / "t3"),
                "--seeds", "2", env=env)
    assert "NDRQL_WEIGHTS" in assert_one_line_error(r, "missing model weights")
