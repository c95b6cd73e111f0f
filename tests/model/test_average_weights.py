"""``ndrql average-weights``: the weighted mean of two models, recorded; bad input in one line."""

from __future__ import annotations

import torch

from ndrql.model.checkpoint import average_weights, load_checkpoint
from ndrql.model.weights import shipped_weights

from helpers.cli import assert_one_line_error, run_cli


def _scaled_copy(src, dst, factor: float) -> None:
    """The shipped general model with every float tensor multiplied by ``factor`` (a second 'model')."""
    data = load_checkpoint(src)
    data["model"] = {k: (v.float() * factor).half() if v.is_floating_point() else v for k, v in data["model"].items()}
    torch.save(data, dst)


def test_weighted_mean_by_hand(tmp_path):
    a = shipped_weights("general")
    _scaled_copy(a, tmp_path / "b.pt", 3.0)
    out = average_weights([a, tmp_path / "b.pt"], tmp_path / "soup.pt", [1.0, 3.0])
    soup, wa, wb = (load_checkpoint(p) for p in (out, a, tmp_path / "b.pt"))
    assert soup["config"] == wa["config"]
    for key, va in wa["model"].items():
        got = soup["model"][key]
        if va.is_floating_point():
            want = (0.25 * va.float() + 0.75 * wb["model"][key].float()).half()
            assert got.dtype == torch.float16 and torch.equal(got, want), key
        else:
            assert torch.equal(got, va), key  # integer counters come from the first file
    rec = soup["averaged_from"]
    assert [r["share"] for r in rec] == [0.25, 0.75] and rec[0]["file"] == a.name and len(rec[1]["sha256"]) == 64


def test_cli_average_and_bad_input(ndrql_exe, tmp_path):
    a, b = shipped_weights("general"), shipped_weights("paper")
    ok = run_cli(ndrql_exe, "average-weights", str(a), str(a), "--out", str(tmp_path / "same.pt"))
    assert ok.returncode == 0, ok.stderr
    same, original = load_checkpoint(tmp_path / "same.pt")["model"], load_checkpoint(a)["model"]
    assert same.keys() == original.keys()
    assert all(torch.equal(v, original[k]) for k, v in same.items())  # the mean of one model is itself
    # paper and general differ in input mode: another architecture config
    assert_one_line_error(run_cli(ndrql_exe, "average-weights", str(a), str(b), "--out", str(tmp_path / "x.pt")),
                          "has another architecture")
    assert_one_line_error(run_cli(ndrql_exe, "average-weights", str(a), "--out", str(tmp_path / "x.pt")), "at least two")
    assert_one_line_error(run_cli(ndrql_exe, "average-weights", str(a), str(a), "--shares", "1,x", "--out", str(tmp_path / "x.pt")),
                          "--shares must be numbers")
    assert_one_line_error(run_cli(ndrql_exe, "average-weights", str(a), str(a), "--shares", "1,0", "--out", str(tmp_path / "x.pt")),
                          "one positive share per weights file")
    copy = tmp_path / "c.pt"
    copy.write_bytes(a.read_bytes())
    assert_one_line_error(run_cli(ndrql_exe, "average-weights", str(copy), str(a), "--out", str(copy)), "is one of the inputs")
    assert copy.read_bytes() == a.read_bytes()
    assert not (tmp_path / "x.pt").exists()
