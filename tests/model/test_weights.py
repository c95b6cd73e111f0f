"""``--weights paper|general|FILE``: names of the shipped weights, ``$NDRQL_WEIGHTS``, paths."""

from __future__ import annotations

from pathlib import Path

from ndrql.model.weights import DEFAULT_WEIGHTS, SHIPPED_WEIGHTS, installed, resolve_weights, shipped_weights, weights_label

from helpers.cli import run_cli


def test_names_mean_the_shipped_files(monkeypatch):
    monkeypatch.delenv("NDRQL_WEIGHTS", raising=False)
    for name, file in SHIPPED_WEIGHTS.items():
        if not installed(name):  # belief ships once trained (tests/model/test_belief_weights.py)
            continue
        path = resolve_weights(name)
        assert path.name == file and path.is_file() and weights_label(path) == name
    assert resolve_weights(None) == shipped_weights(DEFAULT_WEIGHTS)
    assert resolve_weights(None, "general") == shipped_weights("general")


def test_environment_and_paths(monkeypatch, tmp_path):
    monkeypatch.setenv("NDRQL_WEIGHTS", "general")
    assert resolve_weights(None, "paper") == shipped_weights("general")  # the variable wins over a default
    assert resolve_weights("paper") == shipped_weights("paper")  # an explicit name wins over the variable
    monkeypatch.setenv("NDRQL_WEIGHTS", str(tmp_path / "w.pt"))
    assert resolve_weights(None) == tmp_path / "w.pt"
    assert resolve_weights(Path("x/general")) == Path("x/general")  # a path that is not a bare name
    assert weights_label(tmp_path / "w.pt") == str(tmp_path / "w.pt")


def test_plan_takes_a_name_or_a_file(ndrql_exe, tmp_path):
    """``--weights paper`` plans with the paper model and says so; a missing FILE is one line, exit 2."""
    import json

    sample = shipped_weights("paper").with_name("sample_map.png")
    args = ["plan", str(sample), "--start", "25,179", "--goal", "167,5", "--size", "50", "--seeds", "1"]
    ok = run_cli(ndrql_exe, *args, "--weights", "paper", "--json", str(tmp_path / "p.json"))
    assert ok.returncode == 0, ok.stderr
    assert Path(json.loads((tmp_path / "p.json").read_text())["weights"]).name == SHIPPED_WEIGHTS["paper"]
    bad = run_cli(ndrql_exe, *args, "--weights", str(tmp_path / "none.pt"))
    errors = [line for line in bad.stderr.splitlines() if line.startswith("ndrql: error")]
    assert bad.returncode == 2 and len(errors) == 1 and "none.pt" in errors[0]
