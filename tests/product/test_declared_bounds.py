"""Declared bounds (ndrql.limits.BOUNDS): every numeric flag of every subcommand, every numeric field of the
planning configs and every NDRQL_* variable has a declared range, the defaults lie in it, and a value beyond
it is one line, exit code 2, before any work (in process through main())."""

from __future__ import annotations

import argparse
import dataclasses
import re
from pathlib import Path

import pytest

from ndrql.cli import build_parser, main
from ndrql.cli.options import numeric_values
from ndrql.errors import BoundError, CheckpointError, NdrqlError
from ndrql.limits import BOUNDS, ENV_VARS, MAX_THREADS, bound_for, check_bound, field_key
from ndrql.pipeline.settings import NUMERIC_SETTINGS, PlanSettings
from ndrql.planning.config import PriorConfig, QLConfig

SRC = Path(__file__).resolve().parents[2] / "src" / "ndrql"
#: Flags whose value holds numbers but is not a number: checked where they are read.
NOT_NUMBERS = {"--model-overrides": "a JSON mapping of model options, checked by the model registry"}


def _leaves(parser, prefix=()):
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield " ".join(prefix), parser
        return
    for name, sub in subs[0].choices.items():
        yield from _leaves(sub, prefix + (name,))


def _numeric(action: argparse.Action) -> bool:
    if action.type in (int, float):
        return True
    if numeric_values(action.default):
        return not isinstance(action, (argparse._StoreConstAction, argparse._CountAction))
    try:
        return bool(numeric_values(action.type("7"))) if callable(action.type) else False
    except Exception:  # noqa: BLE001 - a type that does not take a number
        return False


def numeric_flags() -> list[tuple[str, argparse.Action]]:
    return [(cmd, a) for cmd, parser in _leaves(build_parser()) for a in parser._actions
            if a.option_strings and a.choices is None and a.option_strings[-1] not in NOT_NUMBERS and _numeric(a)]


def test_every_numeric_flag_has_a_declared_range_and_its_default_lies_in_it():
    flags = numeric_flags()
    assert len(flags) > 100  # the walk sees the subcommands
    missing = sorted({f"{cmd} {a.option_strings[-1]}" for cmd, a in flags if bound_for(a.option_strings[-1], cmd) is None})
    assert missing == [], f"declare these in ndrql.limits.BOUNDS: {missing}"
    for cmd, a in flags:
        for v in numeric_values(a.default):
            check_bound(v, bound_for(a.option_strings[-1], cmd), f"{cmd} {a.option_strings[-1]}")


def test_the_walk_would_catch_a_new_flag():
    parser = argparse.ArgumentParser(prog="ndrql plan")
    parser.add_argument("--brand-new-knob", type=float)
    assert bound_for("--brand-new-knob", "plan") is None and _numeric(parser._actions[-1])


@pytest.mark.parametrize("cls", [QLConfig, PriorConfig, PlanSettings])
def test_every_numeric_config_field_has_a_declared_range(cls):
    numeric = [f.name for f in dataclasses.fields(cls) if re.search(r"\b(int|float)\b", str(f.type))]
    assert numeric and [n for n in numeric if field_key(cls.__name__, n) not in BOUNDS] == []
    if cls is PlanSettings:
        assert set(numeric) == set(NUMERIC_SETTINGS)


def test_every_environment_variable_is_declared():
    used = {m for p in SRC.rglob("*.py") for m in re.findall(r"\bNDRQL_[A-Z_]+\b", p.read_text(encoding="utf-8"))}
    assert used and sorted(used - set(ENV_VARS)) == []


@pytest.mark.parametrize("argv", [
    ["plan", "--example", "--thd-step", "1e-300"],
    ["plan", "--example", "--path-spacing", "1e-6"],
    ["plan", "--example", "--records", "--window", "10000000000"],
    ["plan", "--example", "--max-steps", "99999999999"],
    ["plan", "--example", "--g-row", "1e-30"],
    ["plan", "--example", "--alpha", "nan"],
    ["plan", "--example", "--max-pixels", "99999999999"],
    ["data", "show", "set", "--grid", "1000000", "--png", "a.png"],
    ["train", "--threads", str(MAX_THREADS + 1)],
    ["train", "--steps-per-epoch", "-1"],
    ["train", "--checkpoint-minutes", "0"],
    ["eval", "--batch-size", "100000"],
    ["tune", "--trials", "0"],
    ["export-onnx", "--out", "x.onnx", "--size", "100000"],
    ["data", "generate", "--family", "all", "--count", "1", "--size", "100000", "--out", "d"],
    ["reproduce", "table1", "--seeds", "0"],
])
def test_a_value_beyond_its_range_is_one_line_before_any_work(argv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    flag = next(a for a, v in zip(reversed(argv[:-1]), reversed(argv)) if a.startswith("--") and v[:1] in "-0123456789n")
    assert err.startswith(f"ndrql: error: {flag} must be") and err.count("\n") == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_the_api_raises_the_same_bounds_as_ndrql_errors():
    for build in (lambda: PriorConfig(thd_step=1e-300), lambda: QLConfig(window=10**10), lambda: PriorConfig(g_row=1e9),
                  lambda: PlanSettings(robot_radius=1e9)):
        with pytest.raises(NdrqlError, match="must be"):
            build()
    assert issubclass(BoundError, ValueError)


def test_a_zero_stride_checkpoint_tensor_is_refused_before_it_is_copied(tmp_path):
    torch = pytest.importorskip("torch")
    from ndrql.model.checkpoint import FORMAT, FORMAT_VERSION, load_checkpoint

    path = tmp_path / "huge.pt"
    torch.save({"format": FORMAT, "format_version": FORMAT_VERSION, "config": {},
                "model": {"w": torch.zeros(1).expand(60000, 60000)}}, path)
    assert path.stat().st_size < 10_000
    with pytest.raises(CheckpointError, match="does not fit"):
        load_checkpoint(path)


def test_the_tuning_search_space_lies_inside_the_declared_bounds():
    from ndrql.planning.methods import METHODS
    from ndrql.tuning.space import search_space

    for method in METHODS:
        for p in search_space(method):
            names = ("g_row", "g_col") if p.name == "G" else (p.name,)
            for name in names:
                cls = "QLConfig" if name in {f.name for f in dataclasses.fields(QLConfig)} else "PriorConfig"
                bound = BOUNDS[field_key(cls, name)]
                assert bound.lo <= p.low and p.high <= bound.hi, (method, name, p.low, p.high, bound)


def test_records_are_bounded_by_what_they_keep(capsys, tmp_path, monkeypatch):
    """--records keeps every episode of every run (2 million took 1 GB): runs x episodes at most 10^6."""
    monkeypatch.chdir(tmp_path)
    for extra in (["--max-episodes", "2000000"], ["--seeds", "60"]):
        assert main(["plan", "--example", "--method", "QL", "--records", "--json", "r.json", *extra]) == 2
        err = capsys.readouterr().err
        assert err.startswith("ndrql: error: --records keeps every episode") and err.count("\n") == 1, err
    assert not (tmp_path / "r.json").exists()
