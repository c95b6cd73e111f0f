"""The training loop on a tiny dataset: checkpoints, exact resume, metrics CSV, ndrql eval/predict."""

from __future__ import annotations


import numpy as np
import pytest
import torch

from ndrql.errors import CheckpointError
from ndrql.model.checkpoint import load_checkpoint
from ndrql.training.config import TrainConfig
from ndrql.training.loop import train

from helpers.cli import assert_one_line_error, run_cli

TINY = {"width": 0.25}


def config(root, **kw) -> TrainConfig:
    base = dict(data=str(root), model="ndr-stdc1-half", model_overrides=TINY, batch_size=4, epochs=2,
                val_fraction=0.25, warmup_steps=2, bf16=False, threads=1)
    base.update(kw)
    return TrainConfig(**base)


def test_resume_continues_exactly(tiny_dataset, tmp_path):
    torch.manual_seed(0)
    train(config(tiny_dataset), tmp_path / "straight", progress=False, log=lambda m: None)
    torch.manual_seed(0)
    state = train(config(tiny_dataset, max_steps=4), tmp_path / "split", progress=False, log=lambda m: None)
    assert state["global_step"] == 4 and state["epoch"] == 1 and state["step"] == 1  # 3 steps per epoch
    train(config(tiny_dataset), tmp_path / "split", resume=True, progress=False, log=lambda m: None)
    a = load_checkpoint(tmp_path / "straight" / "last.pt")
    b = load_checkpoint(tmp_path / "split" / "last.pt")
    assert a["state"]["global_step"] == b["state"]["global_step"] == 6
    for k in a["model"]:
        assert torch.allclose(a["model"][k].float(), b["model"][k].float(), atol=1e-5), k
    rows = (tmp_path / "split" / "metrics.csv").read_text().strip().splitlines()
    assert len(rows) == 3 and rows[0].startswith("epoch,")
    assert (tmp_path / "split" / "best.pt").exists()


def test_refuses_to_overwrite_or_resume_another_model(tiny_dataset, tmp_path):
    train(config(tiny_dataset, max_steps=1), tmp_path / "r", progress=False, log=lambda m: None)
    with pytest.raises(CheckpointError, match="pass --resume"):
        train(config(tiny_dataset, max_steps=1), tmp_path / "r", progress=False, log=lambda m: None)
    with pytest.raises(CheckpointError, match="same --model"):
        train(config(tiny_dataset, model_overrides={"width": 0.5}, max_steps=1), tmp_path / "r", resume=True, progress=False, log=lambda m: None)


@pytest.mark.slow
def test_eval_and_predict_cli_on_a_trained_checkpoint(tiny_dataset, tmp_path, ndrql_exe):
    import os

    train(config(tiny_dataset, epochs=1), tmp_path / "run", progress=False, log=lambda m: None)
    env = {**os.environ}
    weights = tmp_path / "run" / "best.pt"
    out = run_cli(ndrql_exe, "eval", "--split", "unseen", "--data", str(tiny_dataset), "--weights", str(weights),
                  "--json", str(tmp_path / "e.json"), env=env)
    assert out.returncode == 0, out.stderr
    assert "region F1 (original labels)" in out.stdout and "| all | 4 |" in out.stdout
    out = run_cli(ndrql_exe, "predict", "--sample", f"{tiny_dataset}:seen:1", "--weights", str(weights),
                  "--out", str(tmp_path / "pred"), env=env)
    assert out.returncode == 0, out.stderr
    z = np.load(tmp_path / "pred" / "prediction.npz")
    assert z["region"].shape == (201, 201) and z["guideline"].shape == (201, 201)
    assert 0 <= z["region"].min() and z["region"].max() <= 1
    assert (tmp_path / "pred" / "region.png").stat().st_size > 1000
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"\x00" * 10)
    out = run_cli(ndrql_exe, "predict", "--sample", f"{tiny_dataset}:seen:1", "--weights", str(bad), env=env)
    assert assert_one_line_error(out).startswith("ndrql: error: cannot read checkpoint")
