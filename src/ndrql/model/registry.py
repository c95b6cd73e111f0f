"""Model registry: build a network from its config dict, with an error listing valid names."""

from __future__ import annotations

from typing import Callable

from torch import nn

from ndrql.model.ndr import NDRConfig, NDRNet


def _build_ndr(cfg: dict) -> nn.Module:
    return NDRNet(NDRConfig.from_dict(cfg))


def _build_rgp(cfg: dict) -> nn.Module:
    from ndrql.model.rgp import RGPConfig, RGPNet

    return RGPNet(RGPConfig.from_dict(cfg))


#: Architecture name -> builder taking the config dict saved in a checkpoint.
ARCHITECTURES: dict[str, Callable[[dict], nn.Module]] = {"ndr": _build_ndr, "rgp": _build_rgp}

#: Named presets for ``ndrql train --model``.
PRESETS: dict[str, dict] = {
    "ndr-stdc1": {"arch": "ndr", "encoding": "point", "backbone": "stdc1", "width": 1.0},
    "ndr-stdc1-half": {"arch": "ndr", "encoding": "point", "backbone": "stdc1", "width": 0.5, "unet_base": 8},
    "ndr-stdc1-quarter": {"arch": "ndr", "encoding": "point", "backbone": "stdc1", "width": 0.25, "unet_base": 8},
    "ndr-stdc2": {"arch": "ndr", "encoding": "point", "backbone": "stdc2", "width": 1.0},
    "ndr-stdc1-half-noguide": {"arch": "ndr", "encoding": "point", "backbone": "stdc1", "width": 0.5, "unet_base": 8, "guideline_decoder": False},
    "rgp": {"arch": "rgp", "encoding": "rgb", "width": 0.5},
}


def build_model(config: dict) -> nn.Module:
    """Instantiate the architecture named by ``config['arch']``."""
    arch = config.get("arch", "ndr")
    if arch not in ARCHITECTURES:
        raise ValueError(f"unknown architecture {arch!r}; valid: {', '.join(ARCHITECTURES)}")
    return ARCHITECTURES[arch](config)


def preset(name: str, **overrides) -> dict:
    """Config dict of a named preset, with overrides applied."""
    if name not in PRESETS:
        raise ValueError(f"unknown model {name!r}; valid: {', '.join(PRESETS)}")
    return {**PRESETS[name], **overrides}
