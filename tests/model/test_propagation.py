"""The shipped propagating head (:mod:`ndrql.model.propagation`): its graph matches its record and torch, it
answers on any grid shape, and what it carries never crosses a wall."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ndrql.io import file_digest
from ndrql.model import propagation


def _two_rooms(extra_wall: bool = False) -> np.ndarray:
    """21x30 grid split by a full wall at column 14: room A (columns 0-13), room B (15-29)."""
    blocked = np.zeros((21, 30), bool)
    blocked[:, 14] = True
    blocked[5:16, 6] = True  # a wall inside A, so the route in A bends
    if extra_wall:
        blocked[3:18, 22] = True  # changes room B only
    return blocked


def test_the_shipped_graph_matches_its_record_and_checkpoint():
    record = propagation.read_record()
    assert record is not None and propagation.available()
    assert file_digest(propagation.graph_file()) == record["onnx_sha256"]
    assert file_digest(propagation.graph_file().with_suffix(".pt")) == record["weights_sha256"]
    assert record["max_difference"] <= 1e-4 and record["chunk"] >= 1 and record["width"] >= 1


def test_onnx_runtime_gives_torch_s_probabilities():
    torch = pytest.importorskip("torch")
    from ndrql.model.propagator import load_propagator

    net = load_propagator(propagation.graph_file().with_suffix(".pt"))
    blocked = _two_rooms()
    got = propagation.propagate(blocked, (2, 2), (18, 12), threads=1)
    iters = propagation.iterations(blocked.shape, propagation.read_record()["chunk"])
    x = torch.as_tensor(propagation.head_input(blocked, (2, 2), (18, 12)))
    with torch.no_grad():
        want = torch.sigmoid(net(x, iters)[0])[0, 0].double().numpy()
    free = ~blocked
    assert np.abs(got[free] - want[free]).max() < 1e-4
    assert (got[blocked] == 0).all() and got.shape == blocked.shape


def test_what_it_carries_never_crosses_a_wall_one_cell_thick():
    a = propagation.propagate(_two_rooms(), (2, 2), (18, 12))
    moved = propagation.propagate(_two_rooms(), (18, 1), (1, 12))  # start and goal moved inside room A
    other = propagation.propagate(_two_rooms(extra_wall=True), (2, 2), (18, 12))  # room B changed
    assert np.array_equal(a[:, 15:], moved[:, 15:])  # B does not see where start and goal are
    assert np.array_equal(a[:, :14], other[:, :14])  # A does not see B's walls


@pytest.mark.parametrize("shape,chunk,want", [((256, 256), 8, 256), ((250, 200), 8, 256), ((5, 3), 8, 8),
                                              ((10, 4), 8, 16), ((300, 512), 1, 512)])
def test_iterations_follow_the_longer_side_in_whole_calls(shape, chunk, want):
    assert propagation.iterations(shape, chunk) == want


def test_a_record_that_does_not_match_the_graph_means_no_head(tmp_path, monkeypatch):
    graph = tmp_path / "propagator.onnx"
    graph.write_bytes(propagation.graph_file().read_bytes())
    (tmp_path / "propagator.json").write_text(json.dumps({**propagation.read_record(), "onnx_sha256": "0" * 64}))
    monkeypatch.setattr(propagation, "data_dir", lambda: tmp_path)
    propagation.available.cache_clear()
    try:
        assert not propagation.available()
        (tmp_path / "propagator.json").write_text("not json")
        propagation.available.cache_clear()
        assert not propagation.available()
    finally:
        propagation.available.cache_clear()


@pytest.mark.parametrize("pool", [False, True])
def test_export_gives_a_graph_that_matches_torch(tmp_path, pool):
    torch = pytest.importorskip("torch")
    pytest.importorskip("onnx")
    from ndrql.model.propagator import Propagator, export_propagator

    torch.manual_seed(0)
    net = Propagator(4, pool)
    torch.save({"state": net.state_dict(), "width": 4, "pool": pool}, tmp_path / "p.pt")
    worst = export_propagator(tmp_path / "p.pt", tmp_path / "p.onnx")
    assert worst <= 1e-4 and (tmp_path / "p.onnx").stat().st_size > 0
