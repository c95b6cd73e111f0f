"""A checkpoint shaped like the shipped belief model (issue 54): general warm-started with the unknown channel.

Until ``ndr_belief.pt`` ships, tests build it here: :func:`ndrql.training.start.warm_start` gives the fourth input
channel zero weights, so the network predicts what ``general`` predicts on the belief (unknown counted free).
"""

from __future__ import annotations

from pathlib import Path

#: The shipped belief model's configuration (``tools/train_belief.sh``).
BELIEF_CONFIG = dict(model="ndr-stdc1-half", encoding="point+unknown", input_mode="grid", distance_head=True,
                     distance_decoder="skips")


def warm_belief_checkpoint(path: Path) -> Path:
    """Write the warm-started checkpoint to ``path`` (torch needed) and return it."""
    import torch

    from ndrql.model.checkpoint import save_checkpoint
    from ndrql.model.registry import build_model
    from ndrql.model.weights import shipped_weights
    from ndrql.training.config import TrainConfig
    from ndrql.training.start import warm_start

    torch.manual_seed(0)
    cfg = TrainConfig(**BELIEF_CONFIG).model_config()
    model = build_model(cfg)
    warm_start(model, str(shipped_weights("general")), cfg)
    return Path(save_checkpoint(path, {"config": cfg, "model": model.state_dict()}))
