"""The NDR and RGP networks: forward contract, registry, learning, checkpoints."""

from __future__ import annotations

import pytest
import torch

from ndrql.errors import CheckpointError
from ndrql.model.ndr import NDRConfig, NDRNet
from ndrql.model.registry import PRESETS, build_model, preset
from ndrql.model.checkpoint import export_weights, load_checkpoint, model_from_checkpoint, save_checkpoint
from ndrql.training.losses import ndr_loss

TINY = {"arch": "ndr", "encoding": "point", "backbone": "stdc1", "width": 0.25, "unet_base": 8}


@pytest.fixture(autouse=True)
def _seed():
    torch.manual_seed(0)


@pytest.mark.parametrize("config", [TINY, {**TINY, "guideline_decoder": False}, {"arch": "rgp", "encoding": "rgb", "width": 0.25}])
@pytest.mark.parametrize("size", [(201, 201), (256, 256), (150, 233)])
def test_outputs_come_back_at_input_size(config, size):
    model = build_model(config).eval()
    with torch.no_grad():
        region, guide = model(torch.zeros(2, 3, *size))
    assert region.shape == (2, 1, *size)
    if config.get("guideline_decoder", True):
        assert guide.shape == (2, 1, *size)
    else:
        assert guide is None


def test_wrong_input_channels_says_what_to_do():
    with pytest.raises(ValueError, match=r"expected input \(B, 3, H, W\).*encode_input"):
        NDRNet(NDRConfig(width=0.25))(torch.zeros(1, 4, 64, 64))


def test_registry_errors_list_valid_names():
    with pytest.raises(ValueError, match="valid: .*ndr-stdc1-half"):
        preset("resnet-9000")
    with pytest.raises(ValueError, match="valid: ndr, rgp"):
        build_model({"arch": "vit"})
    with pytest.raises(ValueError, match="valid: stdc1, stdc2"):
        build_model({"arch": "ndr", "backbone": "stdc3"})


def test_stdc_presets_have_paper_shapes():
    full = build_model(PRESETS["ndr-stdc1"])
    assert full.backbone.out_channels == (256, 512, 1024)
    assert build_model(PRESETS["ndr-stdc1-half"]).backbone.out_channels == (128, 256, 512)
    stdc2 = build_model(PRESETS["ndr-stdc2"])
    assert [len(s) for s in stdc2.backbone.stages] == [4, 5, 3]


def _toy_batch(n: int = 4, side: int = 64):
    g = torch.Generator().manual_seed(1)
    x = torch.zeros(n, 3, side, side)
    x[:, 0] = (torch.rand(n, side, side, generator=g) > 0.9).float()
    region = torch.zeros(n, 1, side, side)
    guide = torch.zeros(n, 1, side, side)
    for i in range(n):
        r = 8 + 10 * i
        x[i, 1, r, 4] = 1
        x[i, 2, r, side - 5] = 1
        region[i, 0, r - 4:r + 5, 2:side - 2] = 1
        guide[i, 0, r:r + 2, 4:side - 4] = 1
    return x, region, guide


def test_a_few_steps_lower_the_loss():
    model = build_model(TINY).train()
    opt = torch.optim.AdamW(model.parameters(), lr=3e-3)
    x, region, guide = _toy_batch()
    losses = []
    for _ in range(25):
        r, g = model(x)
        loss = ndr_loss(r, g, region, guide)
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(float(loss.detach()))
    assert losses[-1] < 0.8 * losses[0], losses


def test_checkpoint_round_trip_gives_identical_outputs(tmp_path):
    model = build_model(TINY).eval()
    x, *_ = _toy_batch()
    path = save_checkpoint(tmp_path / "m.pt", {"config": TINY, "model": model.state_dict()})
    again = model_from_checkpoint(load_checkpoint(path))
    with torch.no_grad():
        a, b = model(x), again(x)
    assert torch.equal(a[0], b[0]) and torch.equal(a[1], b[1])
    slim = export_weights(path, tmp_path / "slim.pt")
    half = model_from_checkpoint(load_checkpoint(slim))
    with torch.no_grad():
        assert torch.allclose(torch.sigmoid(half(x)[0]), torch.sigmoid(a[0]), atol=2e-2)


def test_bad_checkpoints_give_clear_errors(tmp_path):
    with pytest.raises(CheckpointError, match="not found"):
        load_checkpoint(tmp_path / "missing.pt")
    junk = tmp_path / "junk.pt"
    junk.write_bytes(b"not a torch file at all")
    with pytest.raises(CheckpointError, match="cannot read checkpoint"):
        load_checkpoint(junk)
    foreign = tmp_path / "foreign.pt"
    torch.save({"state_dict": {}}, foreign)
    with pytest.raises(CheckpointError, match="not an ndrql checkpoint"):
        load_checkpoint(foreign)
    model = build_model(TINY)
    newer = save_checkpoint(tmp_path / "newer.pt", {"config": TINY, "model": model.state_dict()})
    data = torch.load(newer, weights_only=True)
    data["format_version"] = 99
    torch.save(data, newer)
    with pytest.raises(CheckpointError, match="format 99"):
        load_checkpoint(newer)
    other_arch = save_checkpoint(tmp_path / "other.pt", {"config": {**TINY, "width": 0.5}, "model": model.state_dict()})
    with pytest.raises(CheckpointError, match="do not fit the architecture"):
        model_from_checkpoint(load_checkpoint(other_arch))
    unknown = save_checkpoint(tmp_path / "unknown.pt", {"config": {"arch": "transformer"}, "model": {}})
    with pytest.raises(CheckpointError, match="valid: ndr, rgp"):
        model_from_checkpoint(load_checkpoint(unknown))


def test_export_pooling_equals_adaptive_pooling():
    from ndrql.model.context import adaptive_mean

    x = torch.randn(2, 5, 7, 9)
    for bins in (1, 2, 4):
        assert torch.allclose(adaptive_mean(x, bins), torch.nn.functional.adaptive_avg_pool2d(x, bins), atol=1e-6)


def test_shipped_weights_load_and_predict_sensibly():
    import numpy as np

    from ndrql.model.predict import Predictor, default_weights_path

    if not default_weights_path().is_file():
        pytest.skip(f"no shipped weights at {default_weights_path()}")
    obstacles = np.zeros((201, 201), bool)
    obstacles[60:140, 60:140] = True  # one block in the middle
    pred = Predictor.load().predict(obstacles, (10, 10), (190, 190))
    assert pred.region.shape == (201, 201)
    # the predicted region covers the endpoints and mostly avoids the block
    assert pred.region[10, 10] > 0.5 and pred.region[190, 190] > 0.5
    assert pred.region[obstacles].mean() < pred.region[~obstacles].mean()


def _onnx_vs_torch(model, onnx_path, shape):
    """Largest |probability difference| between ``model`` and the graph on one input of ``shape``."""
    import onnxruntime as ort

    b, c, h, w = shape
    x = torch.zeros(shape)
    x[:, 0, h // 4: h // 3, 2: w - 5] = 1
    x[:, 1, 5, 5] = 1
    x[:, 2, h - 6, w - 6] = 1
    with torch.no_grad():
        r, g = model(x)
    ro, go = ort.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"]).run(None, {"x": x.numpy()})
    assert ro.shape == go.shape == (b, 1, h, w)
    return max(float(abs(torch.sigmoid(torch.from_numpy(ro)) - torch.sigmoid(r)).max()),
               float(abs(torch.sigmoid(torch.from_numpy(go)) - torch.sigmoid(g)).max()))


def test_onnx_export_matches_torch_at_any_side(tmp_path):
    pytest.importorskip("onnx", reason="ONNX export needs onnx: pip install 'ndrql[train]'")
    pytest.importorskip("onnxruntime")
    import onnx

    from ndrql.model.export import export_onnx

    torch.manual_seed(0)
    model = build_model(TINY).eval()
    for m in model.modules():  # BatchNorm statistics away from the identity, so folding them matters
        if isinstance(m, torch.nn.BatchNorm2d):
            m.running_mean.uniform_(-0.5, 0.5)
            m.running_var.uniform_(0.5, 2.0)
    full = save_checkpoint(tmp_path / "m.pt", {"config": TINY, "model": model.state_dict()})
    half = export_weights(full, tmp_path / "half.pt")  # fp16 weights, as the shipped files
    model = model_from_checkpoint(load_checkpoint(half))
    any_side = export_onnx(half, tmp_path / "any.onnx")
    for shape in [(2, 3, 201, 201), (1, 3, 96, 96), (1, 3, 250, 250), (1, 3, 130, 77), (1, 3, 448, 448)]:
        assert _onnx_vs_torch(model, any_side, shape) < 1e-4, shape
    # fp16 weights are stored as fp16 (about half the file) and cast back exactly; fp32 weights stay fp32
    graph = onnx.load(str(any_side)).graph
    assert sum(i.data_type == onnx.TensorProto.FLOAT16 for i in graph.initializer) > 10
    full_graph = export_onnx(full, tmp_path / "full.onnx")
    assert any_side.stat().st_size < 0.6 * full_graph.stat().st_size
    assert _onnx_vs_torch(model_from_checkpoint(load_checkpoint(full)), full_graph, (1, 3, 160, 160)) < 1e-4
    fixed = export_onnx(half, tmp_path / "fixed.onnx", size=201)
    assert _onnx_vs_torch(model, fixed, (2, 3, 201, 201)) < 1e-4
