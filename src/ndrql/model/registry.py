"""Model registry: build a network from its config dict, with an error listing valid names.

A config comes from a preset, the command line or a checkpoint file (which anyone can craft), so
:func:`check_config` checks every field's type and range (:data:`LIMITS`) before a network is
built: a bad config is one ``ValueError`` line, never a traceback or a multi-gigabyte allocation.
"""

from __future__ import annotations

import math
from dataclasses import fields
from typing import Any, Callable

from torch import nn

from ndrql.dataset.encodings import ENCODINGS, UNKNOWN_ENCODINGS, encoding_channels
from ndrql.errors import brief
from ndrql.model.backbone import STDC_DEPTHS
from ndrql.model.ndr import DISTANCE_DECODERS, NDRConfig, NDRNet
from ndrql.model.rgp import RGPConfig, RGPNet


def _build_ndr(cfg: dict) -> nn.Module:
    return NDRNet(NDRConfig.from_dict(cfg))


def _build_rgp(cfg: dict) -> nn.Module:
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


#: Allowed range of each numeric config field (inclusive); the presets use width 0.25..1.0.
LIMITS: dict[str, tuple[float, float]] = {
    "width": (0.0625, 2.0),
    "in_channels": (1, 16),
    "context_channels": (1, 1024),
    "fusion_channels": (1, 1024),
    "unet_base": (1, 256),
    "decoder_channels": (1, 512),
}

#: Allowed values of the named config fields.
CHOICES: dict[str, tuple[str, ...]] = {"backbone": tuple(STDC_DEPTHS), "distance_decoder": tuple(DISTANCE_DECODERS)}


def _config_class(arch: str) -> Any:
    if arch == "rgp":
        return RGPConfig
    return NDRConfig


def _check_field(name: str, value: Any, default: Any) -> None:
    if isinstance(default, bool):
        ok = isinstance(value, bool)
    elif isinstance(default, int):
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif isinstance(default, float):
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    elif isinstance(default, str):
        ok = isinstance(value, str)
    elif isinstance(default, tuple):
        ok = (isinstance(value, (list, tuple)) and len(value) == len(default)
              and all(isinstance(v, int) and not isinstance(v, bool) for v in value))
    else:
        ok = True
    if not ok:
        raise ValueError(f"model config field {name!r} must be like {default!r}, got {brief(value)}")
    lo_hi = LIMITS.get(name)
    if lo_hi is not None:
        for v in value if isinstance(value, (list, tuple)) else (value,):
            if not lo_hi[0] <= v <= lo_hi[1]:
                raise ValueError(f"model config field {name!r} must be in {lo_hi[0]}..{lo_hi[1]}, got {brief(v)}")
    if name in CHOICES and value not in CHOICES[name]:
        raise ValueError(f"unknown {name} {brief(value)} in the model config; valid: {', '.join(CHOICES[name])}")
    if name == "encoding":
        if value not in ENCODINGS and value not in UNKNOWN_ENCODINGS:
            raise ValueError(f"unknown encoding {brief(value)}; valid: {', '.join([*ENCODINGS, *UNKNOWN_ENCODINGS])}")


def check_config(config: Any) -> dict:
    """``config`` as a dict after checking the architecture and every field's type and range.

    ``ValueError`` (one line) for anything else: not a mapping, an unknown architecture or field, a
    value of the wrong type or outside :data:`LIMITS`.
    """
    if not isinstance(config, dict):
        raise ValueError(f"a model config is a mapping of fields, got {type(config).__name__}")
    arch = config.get("arch", "ndr")
    if not isinstance(arch, str) or arch not in ARCHITECTURES:
        raise ValueError(f"unknown architecture {brief(arch)}; valid: {', '.join(ARCHITECTURES)}")
    cls = _config_class(arch)
    defaults = {f.name: f.default for f in fields(cls)}
    unknown = [k for k in config if k not in defaults]
    if unknown:
        raise ValueError(f"unknown config fields for {arch}: {', '.join(brief(k) for k in unknown[:5])}")
    for name, value in config.items():
        _check_field(name, value, defaults[name])
    encoding = config.get("encoding", defaults.get("encoding"))
    if arch == "ndr":  # the input channels are the encoding's (an unknown channel makes four)
        want = encoding_channels(str(encoding))
        if config.get("in_channels", defaults["in_channels"]) != want:
            raise ValueError(f"model config: encoding {brief(encoding)} takes in_channels {want}, got "
                             f"{brief(config.get('in_channels', defaults['in_channels']))}")
    return dict(config)


def build_model(config: dict) -> nn.Module:
    """Instantiate the architecture named by ``config['arch']`` (checked by :func:`check_config` first)."""
    config = check_config(config)
    return ARCHITECTURES[config.get("arch", "ndr")](config)


def preset(name: str, **overrides) -> dict:
    """Config dict of a named preset, with overrides applied."""
    if name not in PRESETS:
        raise ValueError(f"unknown model {name!r}; valid: {', '.join(PRESETS)}")
    return {**PRESETS[name], **overrides}
