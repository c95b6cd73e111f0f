"""The model for belief maps (issue 54): the unknown channel, the warm start from `general`, its checkpoints and ONNX."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from ndrql.dataset.encodings import encode_input, encoding_channels, has_unknown
from ndrql.errors import CheckpointError
from ndrql.model.checkpoint import load_checkpoint, model_from_checkpoint, save_checkpoint
from ndrql.model.predict import Predictor
from ndrql.model.registry import build_model, check_config
from ndrql.training.config import TrainConfig
from ndrql.training.start import warm_start

BELIEF = dict(model="ndr-stdc1-half", encoding="point+unknown", input_mode="grid", distance_head=True,
              distance_decoder="skips")


def _problem(seed: int, side: int = 64):
    rng = np.random.default_rng(seed)
    obstacles = rng.random((side, side)) < 0.2
    start, goal = (5, 6), (side - 7, side - 9)
    obstacles[start] = obstacles[goal] = False
    unknown = rng.random((side, side)) < 0.3
    return obstacles, start, goal, unknown


def test_unknown_encoding_adds_one_channel_equal_to_the_mask():
    obstacles, start, goal, unknown = _problem(0)
    x3 = encode_input(obstacles, start, goal, "point")
    x4 = encode_input(obstacles, start, goal, "point+unknown", unknown)
    assert has_unknown("point+unknown") and not has_unknown("point")
    assert encoding_channels("point+unknown") == 4 and x4.shape == (4, 64, 64)
    np.testing.assert_array_equal(x4[:3], x3)
    np.testing.assert_array_equal(x4[3], unknown.astype(np.float32))
    np.testing.assert_array_equal(encode_input(obstacles, start, goal, "point+unknown")[3], 0.0)  # a known map


def test_unknown_mask_refused_where_it_cannot_go():
    obstacles, start, goal, unknown = _problem(1)
    with pytest.raises(ValueError, match="no unknown channel"):
        encode_input(obstacles, start, goal, "point", unknown)
    with pytest.raises(ValueError, match="unknown mask is"):
        encode_input(obstacles, start, goal, "point+unknown", unknown[:10])


def test_config_names_the_encoding_and_its_channel_count():
    cfg = TrainConfig(**BELIEF).model_config()
    assert cfg["encoding"] == "point+unknown" and cfg["in_channels"] == 4
    with pytest.raises(ValueError, match="takes in_channels 4"):
        check_config({"arch": "ndr", "encoding": "point+unknown"})
    with pytest.raises(ValueError, match="takes in_channels 3"):
        check_config({"arch": "ndr", "encoding": "point", "in_channels": 4})


@pytest.fixture(scope="module")
def warm():
    """(general, the belief model warm-started from it, its config)."""
    torch.manual_seed(0)
    path = str(_general_path())
    general = model_from_checkpoint(load_checkpoint(path))
    cfg = TrainConfig(**BELIEF).model_config()
    model = build_model(cfg)
    warm_start(model, path, cfg)
    return general, model.eval(), cfg


def _general_path():
    from pathlib import Path

    import ndrql

    return Path(ndrql.__file__).parent / "data" / "ndr_general.pt"


def test_warm_start_predicts_what_general_predicts_on_the_belief(warm):
    """At step 0 the unknown channel's weights are zero: whatever it holds, the outputs are general's on the
    belief with its unknown cells counted free (the map channel)."""
    general, model, _ = warm
    for seed in (2, 3):
        obstacles, start, goal, unknown = _problem(seed)
        x3 = torch.from_numpy(encode_input(obstacles, start, goal, "point")[None])
        x4 = torch.from_numpy(encode_input(obstacles, start, goal, "point+unknown", unknown)[None])
        with torch.inference_mode():
            for a, b in zip(general(x3), model(x4)):
                torch.testing.assert_close(b, a, rtol=0, atol=1e-6)


def test_warm_started_model_sees_the_channel_once_trained(warm):
    """The channel is wired: weights that are not zero change the outputs (the test above cannot pass vacuously)."""
    _, model, cfg = warm
    other = build_model(cfg)
    other.load_state_dict(model.state_dict())
    with torch.no_grad():
        other.backbone.stem[0][0].weight[:, 3] += 0.5
    other.eval()
    obstacles, start, goal, unknown = _problem(4)
    x4 = torch.from_numpy(encode_input(obstacles, start, goal, "point+unknown", unknown)[None])
    with torch.inference_mode():
        assert float((model(x4)[0] - other(x4)[0]).abs().max()) > 1e-3


def test_warm_start_refuses_another_architecture(tmp_path, warm):
    _, _, cfg = warm
    wider = build_model({**cfg, "width": 1.0})
    with pytest.raises(CheckpointError, match="holds model"):
        warm_start(wider, str(_general_path()), {**cfg, "width": 1.0})


def test_checkpoint_and_onnx_keep_the_fourth_channel(tmp_path):
    """A saved belief model rebuilds itself (config: encoding and in_channels), and its ONNX graph takes four
    channels and agrees with torch; the Predictor feeds it the unknown cells of a planning grid."""
    pytest.importorskip("onnx")
    pytest.importorskip("onnxruntime")
    from ndrql.model.export import export_onnx, max_differences

    cfg = TrainConfig(**BELIEF).model_config()
    torch.manual_seed(1)
    model = build_model(cfg).eval()  # random weights: the fourth channel's are not zero
    path = save_checkpoint(tmp_path / "belief.pt", {"config": cfg, "model": model.state_dict()})
    data = load_checkpoint(path)
    assert data["config"]["encoding"] == "point+unknown" and data["config"]["in_channels"] == 4
    graph = export_onnx(path, tmp_path / "belief.onnx")
    diffs = max_differences(path, graph, sides=(64,), count=1)
    assert diffs[64]["region"] < 1e-2 and diffs[64]["guideline"] < 1e-2
    blocked = np.zeros((16, 16), bool)
    blocked[4:12, 8] = True
    unknown = np.zeros((16, 16), bool)
    unknown[2:14, 2:6] = True
    for backend in ("torch", "onnx"):
        p = Predictor.load(graph if backend == "onnx" else path, threads=1, backend=backend)
        assert p.sees_unknown
        seen = p.predict_view(blocked, (1, 1), (14, 14), unknown=unknown)
        known = p.predict_view(blocked, (1, 1), (14, 14))
        np.testing.assert_array_equal(seen.seen.unknown[8:12, 8:12], True)  # cell (2, 2) at 4 px per cell
        assert np.abs(seen.region - known.region).max() > 1e-6  # same runner twice: only the channel differs
