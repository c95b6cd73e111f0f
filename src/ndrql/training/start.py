"""How a training run's model starts: warm-started from another checkpoint, with parts of it fixed."""

from __future__ import annotations

import torch
from torch import nn

from ndrql.dataset.encodings import UNKNOWN_ENCODINGS
from ndrql.errors import CheckpointError
from ndrql.model.checkpoint import load_checkpoint


#: Model config fields a warm start may change: what the model sees (mode, view), its distance head and the
#: companion that serves merged grids (a serving detail, ``merged_weights``).
_HEAD_FIELDS = ("input_mode", "distance_head", "distance_decoder", "view", "merged_weights")
#: Layers whose input is the model's input channels followed by the region probability: a new input channel
#: goes before the region's (every other layer that sees the input has it last).
_INPUT_BEFORE_REGION = ("distance.enc2.0.weight",)


def _widened(ck_cfg: dict, model_cfg: dict) -> bool:
    """Whether ``model_cfg`` is ``ck_cfg`` with the unknown channel added to its encoding
    (:data:`~ndrql.dataset.encodings.UNKNOWN_ENCODINGS`)."""
    base = UNKNOWN_ENCODINGS.get(str(model_cfg.get("encoding", "")))
    return base is not None and ck_cfg.get("encoding", "point") == base and ck_cfg.get("in_channels", 3) == 3


def widen_inputs(weights: dict, own: dict, old_channels: int) -> dict:
    """``weights`` for a model whose input has one more channel (the unknown channel, last): every layer that
    sees the input gets that channel's weights at zero (before the region probability in the layers of
    :data:`_INPUT_BEFORE_REGION`, else last), so the widened model predicts exactly what ``weights`` predict
    whatever the channel holds."""
    out = dict(weights)
    for key, w in weights.items():
        target = own.get(key)
        if target is None or target.shape == w.shape:
            continue
        if w.ndim != 4 or target.shape[0] != w.shape[0] or target.shape[1] != w.shape[1] + 1:
            raise CheckpointError(f"--init-weights: {key} is {tuple(w.shape)}, the widened model's {tuple(target.shape)}")
        at = old_channels if key in _INPUT_BEFORE_REGION else w.shape[1]
        zero = torch.zeros_like(w[:, :1])
        out[key] = torch.cat([w[:, :at], zero, w[:, at:]], dim=1)
    return out


def warm_start(model: nn.Module, path: str, model_cfg: dict) -> None:
    """Load the weights of checkpoint ``path`` into ``model`` (same architecture; the input mode may differ,
    and a model with a distance head may start from one without, or with another kind of head: the
    head's layers the checkpoint holds under the same names load, the others keep their initialisation).
    A model whose encoding adds the unknown channel (``point+unknown``) starts from one without it
    (``point``): the new channel's weights start at zero (:func:`widen_inputs`)."""
    ck = load_checkpoint(path)
    widen = _widened(ck["config"], model_cfg)
    skip = _HEAD_FIELDS + (("encoding", "in_channels") if widen else ())
    strip = lambda d: {k: v for k, v in dict(d).items() if k not in skip}  # noqa: E731
    if strip(ck["config"]) != strip(model_cfg) or (ck["config"].get("distance_head") and not model_cfg.get("distance_head")):
        raise CheckpointError(f"--init-weights {path} holds model {ck['config']}, this run builds {model_cfg}")
    own = model.state_dict()
    loaded = {k: v.float() if v.is_floating_point() else v for k, v in ck["model"].items()}
    if widen:
        loaded = widen_inputs(loaded, own, int(ck["config"].get("in_channels", 3)))
    weights = {k: v for k, v in loaded.items()
               if not k.startswith("distance.") or (k in own and own[k].shape == v.shape)}
    fresh = {k: v for k, v in own.items() if k.startswith("distance.") and k not in weights}
    model.load_state_dict({**weights, **fresh})


def freeze_except(model: nn.Module, train_only: str) -> list[nn.Module]:
    """Fix every top-level module of ``model`` not named in ``train_only`` (comma-separated; empty: train
    all); returns the fixed modules (the loop keeps them in eval mode). Unknown names are a one-line error."""
    names = [n.strip() for n in train_only.split(",") if n.strip()]
    if not names:
        return []
    children = dict(model.named_children())
    unknown = [n for n in names if children.get(n) is None]
    if unknown:
        valid = ", ".join(n for n, m in children.items() if m is not None)
        raise CheckpointError(f"--train-only: this model has no part {', '.join(unknown)}; valid: {valid}")
    frozen = [m for n, m in children.items() if n not in names and m is not None]
    for m in frozen:
        m.requires_grad_(False)
    return frozen
