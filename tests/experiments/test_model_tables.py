"""Tables 1 and 4 and the sizing comparison on a tiny dataset: real training, real evaluation, resumable."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ndrql.errors import NdrqlError
from ndrql.experiments.model_runs import evaluate_weights, run_status
from ndrql.experiments.sizing import sizing
from ndrql.experiments.table1 import table1
from ndrql.experiments.table4 import TABLE4_VARIANTS, table4, variant_config
from ndrql.training.config import TrainConfig
from ndrql.training.loop import train

#: Tiny pipeline: quarter-width networks, batch 4, so a variant trains in a few seconds.
BASE = TrainConfig(model_overrides={"width": 0.25}, batch_size=4, val_fraction=0.25, warmup_steps=2, bf16=False)


def quiet(_msg: str) -> None:
    pass


def assert_rectangular(markdown: str) -> None:
    """Every row of every table in ``markdown`` has as many cells as its header."""
    rows = [line for line in markdown.splitlines() if line.startswith("|")]
    assert rows
    assert len({line.count(" | ") for line in rows}) == 1, rows


@pytest.fixture(scope="module")
def table4_runs(tiny_dataset, tmp_path_factory):
    """Every Table 4 variant trained for one epoch on the tiny dataset, two at a time."""
    out = tmp_path_factory.mktemp("t4")
    path = table4(out / "results", data=str(tiny_dataset), epochs=1, run=True, runs=out / "runs", workers=2,
                     progress=False, log=quiet, base=BASE)
    return out, path


@pytest.mark.slow
def test_table4_trains_every_variant_with_one_budget_and_scores_it(table4_runs, tiny_dataset):
    out, path = table4_runs
    text = path.read_text()
    numbers = json.loads((out / "results" / "summary.json").read_text())
    assert set(numbers) == {v.name for v in TABLE4_VARIANTS} and "Not trained yet" not in text
    for v in TABLE4_VARIANTS:
        st = run_status(out / "runs" / "table4" / v.name)
        assert st["finished"] and st["epochs"] == 1 and st["config"]["encoding"] == v.encoding
        assert st["config"].get("guideline_decoder", True) == v.guideline_decoder
        n = numbers[v.name]
        assert 0 <= n["seen"]["region_f1"] <= 100 and n["epochs"] == 1
        # region-only variants have no guideline F1; the GD variant has one
        assert np.isnan(n["seen"]["guideline_f1"]) != v.guideline_decoder
    # the table's numbers are the evaluation of the best checkpoint, not something else
    st = run_status(out / "runs" / "table4" / "point+GD")
    direct = evaluate_weights(st["weights"], tiny_dataset, None, False)
    assert direct["unseen"]["region_f1"] == pytest.approx(numbers["point+GD"]["unseen"]["region_f1"])
    assert f"| point+GD | yes | {numbers['point+GD']['seen']['region_f1']:.2f} |" in text
    assert_rectangular(text)


@pytest.mark.slow
def test_table4_rerun_evaluates_from_cache_without_training(table4_runs, tiny_dataset):
    out, _ = table4_runs
    ckpts = sorted((out / "runs" / "table4").glob("*/last.pt"))
    before = {p: p.stat().st_mtime_ns for p in ckpts}
    evals = sorted((out / "results" / "evals").glob("*.json"))
    assert len(evals) == len(TABLE4_VARIANTS)
    stamps = {p: p.stat().st_mtime_ns for p in evals}
    table4(out / "results", data=str(tiny_dataset), epochs=1, run=True, runs=out / "runs", progress=False,
              log=quiet, base=BASE)
    assert {p: p.stat().st_mtime_ns for p in ckpts} == before
    assert {p: p.stat().st_mtime_ns for p in evals} == stamps


@pytest.mark.slow
def test_table4_refuses_a_different_budget(table4_runs, tiny_dataset):
    out, _ = table4_runs
    with pytest.raises(NdrqlError, match="1-epoch schedule; use --epochs 1"):
        table4(out / "other", data=str(tiny_dataset), epochs=3, run=True, runs=out / "runs", progress=False,
                  log=quiet, base=BASE)
    text = table4(out / "other", data=str(tiny_dataset), epochs=3, runs=out / "runs", progress=False, log=quiet).read_text()
    assert "trained for 1 epochs, not 3" in text and "ndrql reproduce table4 --run --epochs 3" in text
    assert_rectangular(text)


def test_table4_shows_an_unfinished_run_without_scoring_it(tiny_dataset, tmp_path):
    v = TABLE4_VARIANTS[0]
    cfg = variant_config(v, str(tiny_dataset), 2, 1, BASE)
    from dataclasses import replace

    train(replace(cfg, max_steps=1), tmp_path / "runs" / "table4" / v.name, progress=False, log=quiet)
    text = table4(tmp_path / "res", data=str(tiny_dataset), epochs=2, runs=tmp_path / "runs", progress=False,
                     log=quiet).read_text()
    assert f"| {v.name} | no | training: epoch 1/2, step 1 |" in text
    assert "| point+GD | yes | not trained (no checkpoint yet) |" in text
    assert_rectangular(text)
    assert json.loads((tmp_path / "res" / "summary.json").read_text()) == {}


def test_table1_scores_ndr_and_rgp_with_their_budgets(tiny_dataset, tmp_path):
    for model, name in (("ndr-stdc1-half", "ndr"), ("rgp", "rgp")):
        cfg = TrainConfig(**{**BASE.__dict__, "data": str(tiny_dataset), "model": model, "epochs": 1, "threads": 1})
        train(cfg, tmp_path / name, progress=False, log=quiet)
    path = table1(tmp_path / "res", data=str(tiny_dataset), weights=str(tmp_path / "ndr" / "best.pt"),
                     rgp_weights=str(tmp_path / "rgp" / "best.pt"), progress=False, log=quiet)
    numbers = json.loads((tmp_path / "res" / "summary.json").read_text())
    assert set(numbers) == {"NDR", "RGP"}
    assert numbers["RGP"]["training"]["epochs"] == 1 and numbers["RGP"]["training"]["steps"] == 3
    text = path.read_text()
    assert "| RGP (ours) |" in text and "| NDR (paper, reference) | 93.02 | 61.22 | 71.96 | 37.31 |" in text
    assert "Missing" not in text
    assert_rectangular(text)
    text = table1(tmp_path / "res2", data=str(tiny_dataset), weights=str(tmp_path / "ndr" / "best.pt"),
                     rgp_weights=str(tmp_path / "nope.pt"), progress=False, log=quiet).read_text()
    assert "| RGP (ours) | needs weights |" in text and "ndrql train --model rgp" in text
    assert_rectangular(text)


@pytest.mark.slow
def test_sizing_reads_learning_curves(table4_runs, tiny_dataset, tmp_path):
    out, _ = table4_runs
    path = sizing(tmp_path / "sizing", runs=out / "runs", data=str(tiny_dataset), progress=False, log=quiet)
    text = path.read_text()
    numbers = json.loads((tmp_path / "sizing" / "summary.json").read_text())
    assert list(numbers) == ["table4/point+GD"]  # the only sizing run that exists here
    row = numbers["table4/point+GD"]["epochs"][-1]
    assert f"| {row['val_region_f1']:.2f} |" in text and "| quarter width (0.25), bf16 | not trained |" in text
    assert (tmp_path / "sizing" / "sizing.png").stat().st_size > 5000
    test = numbers["table4/point+GD"]["test"]
    assert f"| {test['seen']['region_f1']:.2f} / {test['seen']['guideline_f1']:.2f} |" in text
    assert_rectangular(text)
