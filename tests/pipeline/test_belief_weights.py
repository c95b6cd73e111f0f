"""The shipped belief weights wired in (issue 54): on a belief map with no weights named, plan uses ``belief`` when it
is installed and says so; without it, or with other weights named, the network declines and IQL-BFS runs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")

import ndrql  # noqa: E402
from ndrql.pipeline.prior_stage import BELIEF_MASK  # noqa: E402
from ndrql.errors import FallbackWarning, NdrqlError  # noqa: E402
from ndrql.model import weights as w  # noqa: E402
from ndrql.pipeline.sources import NO_UNKNOWN_CHANNEL  # noqa: E402

from helpers.belief_model import warm_belief_checkpoint  # noqa: E402
from helpers.cli import run_main  # noqa: E402

START, GOAL = (6, 6), (90, 90)
ORIGINAL = w.shipped_weights


def _map() -> np.ndarray:
    m = np.zeros((96, 96), bool)
    m[40:44, 10:80] = True
    return m


def _hidden() -> np.ndarray:
    unknown = np.zeros((96, 96), bool)
    unknown[30:60, 0:50] = True
    return unknown


@pytest.fixture(scope="module")
def belief_file(tmp_path_factory) -> Path:
    return warm_belief_checkpoint(tmp_path_factory.mktemp("belief") / "ndr_belief.pt")


def _install(monkeypatch, path: Path | None) -> None:
    """The package's ``belief`` weights are ``path`` (``None``: not installed)."""
    missing = Path("/nonexistent/ndr_belief.pt")
    monkeypatch.setattr(w, "shipped_weights", lambda name: (path or missing) if name == "belief" else ORIGINAL(name))
    monkeypatch.delenv("NDRQL_WEIGHTS", raising=False)


def _plan(**kw):
    return ndrql.solve(_map(), START, GOAL, methods=["NDR-QL"], seeds=[0], size=24, predict_budget=None, **kw)


def test_a_hidden_map_uses_the_installed_belief_weights_and_says_so(monkeypatch, belief_file, tmp_path):
    _install(monkeypatch, belief_file)
    assert w.plan_weights(None, partial=True) == "belief" and w.weights_label(belief_file) == "belief"
    info = _plan(hide=_hidden()).to_dict()
    assert Path(info["weights"]) == Path(info["request"]["weights"]) == belief_file
    assert info["sources"][0]["source"] == "model" and info["sources"][0]["accepted"]
    assert info["model_input"]["unknown_cells"] > 0 and info["runs"][0]["method"] == "NDR-QL"
    # the CLI builds the same request: the same weights, the same run
    np.save(tmp_path / "map.npy", _map())
    np.save(tmp_path / "mask.npy", _hidden())
    out = run_main(["plan", str(tmp_path / "map.npy"), "--start", "6,6", "--goal", "90,90", "--hide",
                    str(tmp_path / "mask.npy"), "--size", "24", "--seeds", "1", "--predict-budget", "none",
                    "--json", str(tmp_path / "r.json")])
    assert out.returncode == 0, out.stderr
    cli = json.loads((tmp_path / "r.json").read_text())
    assert Path(cli["weights"]) == belief_file and "ndr_belief.pt" in out.stdout, out.stdout
    assert cli["runs"][0]["path"] == info["runs"][0]["path"]
    assert cli["runs"][0]["convergence_steps"] == info["runs"][0]["convergence_steps"]


def test_named_weights_without_the_channel_still_decline(monkeypatch, belief_file):
    _install(monkeypatch, belief_file)
    with pytest.warns(FallbackWarning, match="no input for unknown cells"):
        info = _plan(hide=_hidden(), weights="general").to_dict()
    assert info["weights"] is None and Path(info["request"]["weights"]).name == "ndr_general.pt"
    assert not info["sources"][0]["accepted"] and info["sources"][0]["reason"] == NO_UNKNOWN_CHANNEL
    assert info["runs"][0]["method"] == "IQL-BFS"
    monkeypatch.setenv("NDRQL_WEIGHTS", "general")  # weights named by the environment: the same
    assert w.plan_weights(None, partial=True) is None


def test_without_the_belief_weights_a_hidden_map_takes_the_exact_prior_of_the_belief(monkeypatch):
    """No model with an unknown input: the exact prior of the belief (unknown counted free), Eq. 6's mask off."""
    _install(monkeypatch, None)
    assert not w.installed("belief") and w.plan_weights(None, partial=True) is None
    info = _plan(hide=_hidden()).to_dict()
    assert [t["source"] for t in info["sources"]] == ["exact"] and info["sources"][0]["accepted"]
    assert info["runs"][0]["method"] == "NDR-QL" and info["weights"] == "exact BFS priors"
    assert info["ndr_qi_threshold"]["NDR-QL"] is None and info["qi_mask"] == BELIEF_MASK
    assert info["ndr_qi_threshold_reason"]["NDR-QL"] == BELIEF_MASK
    with pytest.raises(NdrqlError, match="'belief' weights are not installed"):
        w.resolve_weights("belief")


def test_the_installed_belief_model_is_asked_before_the_exact_prior(monkeypatch, belief_file):
    _install(monkeypatch, belief_file)
    info = _plan(hide=_hidden()).to_dict()
    assert info["policy"] == ["model", "exact"] and info["sources"][0]["source"] == "model"
    assert info["ndr_qi_threshold"]["NDR-QL"] is None  # whichever source serves, no mask on a belief map
    assert info["model_input"]["distance_floor"] == "the belief's BFS distance"


def test_a_known_map_keeps_its_exact_prior(monkeypatch, belief_file):
    _install(monkeypatch, belief_file)
    assert w.plan_weights(None, partial=False) is None
    info = _plan().to_dict()
    assert info["sources"][0]["source"] == "exact" and info["runs"][0]["method"] == "NDR-QL"
