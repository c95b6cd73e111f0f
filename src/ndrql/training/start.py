"""How a training run's model starts: warm-started from another checkpoint, with parts of it fixed."""

from __future__ import annotations

from torch import nn

from ndrql.errors import CheckpointError
from ndrql.model.checkpoint import load_checkpoint


#: Model config fields a warm start may change: what the model sees (mode, view) and its distance head.
_HEAD_FIELDS = ("input_mode", "distance_head", "distance_decoder", "view")


def warm_start(model: nn.Module, path: str, model_cfg: dict) -> None:
    """Load the weights of checkpoint ``path`` into ``model`` (same architecture; the input mode may differ,
    and a model with a distance head may start from one without, or with another kind of head: the
    head's layers the checkpoint holds under the same names load, the others keep their initialisation)."""
    ck = load_checkpoint(path)
    strip = lambda d: {k: v for k, v in dict(d).items() if k not in _HEAD_FIELDS}  # noqa: E731
    if strip(ck["config"]) != strip(model_cfg) or (ck["config"].get("distance_head") and not model_cfg.get("distance_head")):
        raise CheckpointError(f"--init-weights {path} holds model {ck['config']}, this run builds {model_cfg}")
    own = model.state_dict()
    weights = {k: v.float() if v.is_floating_point() else v for k, v in ck["model"].items()
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
