"""Self-describing checkpoints: format tag, package version, model config and metrics beside the weights.

Written through the project's one writer (:mod:`ndrql.io`: atomic, no debris even after ``kill -9``)
and read with ``torch.load(weights_only=True)``; the model config is checked against the registry's
limits (:func:`ndrql.model.registry.check_config`) when the file is read, before any network is built.
"""

from __future__ import annotations

import warnings

from pathlib import Path
from typing import Any

import torch

from ndrql.version import __version__
from ndrql.errors import CheckpointError
from ndrql.io import atomic_write, file_digest, note_input
from ndrql.model.companion import CONFIG_KEY as COMPANION_KEY, check_stem
from ndrql.model.registry import build_model, check_config

FORMAT = "ndrql-checkpoint"
#: Bumped when the meaning of saved weights changes; older files give a clear error.
FORMAT_VERSION = 1


def save_checkpoint(path: str | Path, payload: dict[str, Any]) -> Path:
    """Write ``payload`` plus the format header to ``path`` (:func:`ndrql.io.atomic_write`)."""
    data = {"format": FORMAT, "format_version": FORMAT_VERSION, "ndrql_version": __version__, **payload}
    return atomic_write(path, lambda fh: torch.save(data, fh))


def load_checkpoint(path: str | Path, *, note: bool = True) -> dict[str, Any]:
    """Read and validate a checkpoint; every failure is a CheckpointError with the reason. ``note=False``: a
    run's own state (``last.pt`` resumed and rewritten), not one of its inputs (:mod:`ndrql.io.readset`)."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"checkpoint not found: {path}")
    if note:
        note_input(path, "the checkpoint")
    try:
        with warnings.catch_warnings():  # torch's note on a file's pickle protocol precedes our own refusal
            warnings.filterwarnings("ignore", message="Detected pickle protocol", category=UserWarning)
            data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises many types for corrupt or foreign files
        first = str(exc).splitlines()[0] if str(exc) else ""
        if "weights only" in first.lower() or "weights_only" in str(exc) or type(exc).__name__ == "UnpicklingError":
            first = "it holds Python objects besides tensors and plain values, which ndrql refuses to load (loading them could run code)"
        raise CheckpointError(f"cannot read checkpoint {path}: {first or type(exc).__name__}") from None
    check_tensors(data, path)
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise CheckpointError(f"{path} is not an ndrql checkpoint (no '{FORMAT}' header)")
    if data.get("format_version") != FORMAT_VERSION:
        raise CheckpointError(
            f"{path} has checkpoint format {data.get('format_version')} (written by ndrql {data.get('ndrql_version')}); "
            f"this ndrql reads format {FORMAT_VERSION}"
        )
    if "config" not in data or "model" not in data:
        raise CheckpointError(f"{path} lacks the model config or weights")

    try:
        check_config(data["config"])
    except ValueError as exc:
        raise CheckpointError(f"{path}: {exc}") from None
    model = data["model"]
    if not isinstance(model, dict) or not all(isinstance(k, str) and isinstance(v, torch.Tensor) for k, v in model.items()):
        raise CheckpointError(f"{path}: the weights are not a mapping of names to tensors")
    for key in ("train_config", "state", "metrics"):
        if not isinstance(data.get(key, {}), dict):
            raise CheckpointError(f"{path}: {key!r} is not a mapping")
    return data


#: Most elements of one tensor, and of all tensors, in a checkpoint (the shipped models hold under 2**23).
MAX_TENSOR_ELEMENTS, MAX_TOTAL_ELEMENTS = 2**26, 2**27


def check_tensors(data: Any, path: str | Path) -> None:
    """Every tensor in ``data`` (as loaded: views of the file's storage, nothing allocated yet) must fit its
    storage and :data:`MAX_TENSOR_ELEMENTS`; a zero-stride 60000 x 60000 view of a few megabytes would
    become 14 GB at the first copy. :class:`CheckpointError` otherwise."""
    total, stack, seen = 0, [data], 0
    while stack and seen < 100_000:
        item, seen = stack.pop(), seen + 1
        if isinstance(item, dict):
            stack.extend(item.values())
        elif isinstance(item, (list, tuple)):
            stack.extend(item)
        elif isinstance(item, torch.Tensor):
            n = item.numel()
            held = item.untyped_storage().nbytes() // max(1, item.element_size())
            if n > MAX_TENSOR_ELEMENTS or n > held - item.storage_offset() or min(item.stride(), default=1) < 0:
                raise CheckpointError(f"{path}: a tensor of shape {tuple(item.shape)[:8]} does not fit the data the file "
                                      f"holds ({held:,} values) or exceeds {MAX_TENSOR_ELEMENTS:,} values; not a model")
            total += n
    if total > MAX_TOTAL_ELEMENTS or stack:
        raise CheckpointError(f"{path}: more than {MAX_TOTAL_ELEMENTS:,} values or 100,000 entries; not a model")


def model_from_checkpoint(data: dict[str, Any]) -> torch.nn.Module:
    """Rebuild the network from a loaded checkpoint's config and load its weights (fp32)."""
    try:
        model = build_model(dict(data["config"]))
    except (ValueError, TypeError) as exc:
        raise CheckpointError(f"checkpoint config does not describe a known model: {exc}") from None
    state = {k: v.float() if v.is_floating_point() else v for k, v in data["model"].items()}
    try:
        model.load_state_dict(state)
    except RuntimeError as exc:
        raise CheckpointError(f"weights do not fit the architecture in the checkpoint: {str(exc).splitlines()[0]}") from None
    return model.eval()


def export_weights(src: str | Path, dst: str | Path, half: bool = True, extra: dict[str, Any] | None = None,
                   view: str | None = None, merged_weights: str | None = None) -> Path:
    """Write a slim inference checkpoint (config, metrics, fp16 weights, no optimizer) from a training one.
    ``view``: serve a grid-mode model under this view (:class:`ndrql.dataset.views.GridView`; it changes what
    the model is shown above the view's limit, not the weights); ``None`` keeps the checkpoint's.
    ``merged_weights``: the file stem of the companion serving the grids that view merges
    (:mod:`ndrql.model.companion`; a grid-mode model under a ``coarse`` view), ``""`` clears it, ``None``
    keeps the checkpoint's."""
    data = load_checkpoint(src)
    model_cfg = dict(data["config"])
    if view is not None:
        from ndrql.dataset.views import GridView  # lazy: loads scipy

        if model_cfg.get("input_mode", "map") != "grid":
            raise CheckpointError(f"--view applies to grid-mode models; {src} holds a {model_cfg.get('input_mode', 'map')}-mode one")
        parsed = GridView.parse(view)
        model_cfg = {k: v for k, v in model_cfg.items() if k != "view"}
        if str(parsed) != "native":
            model_cfg["view"] = str(parsed)
    if merged_weights is not None:
        model_cfg = {k: v for k, v in model_cfg.items() if k != COMPANION_KEY}
        if merged_weights:
            if not str(model_cfg.get("view") or "native").startswith(("coarse:", "walls:")):
                raise CheckpointError(f"--merged-weights serves the grids a coarse or walls view merges; {src} is served under "
                                      f"view {model_cfg.get('view') or 'native'} ({model_cfg.get('input_mode', 'map')} mode)")
            model_cfg[COMPANION_KEY] = check_stem(merged_weights)
    weights = {k: (v.half() if half and v.is_floating_point() else v) for k, v in data["model"].items()}
    payload = {
        "config": model_cfg,
        "model": weights,
        "metrics": data.get("metrics", {}),
        "train_config": data.get("train_config", {}),
        "state": {k: v for k, v in data.get("state", {}).items() if isinstance(v, (int, float))},
        **(extra or {}),
    }
    return save_checkpoint(dst, payload)


def average_weights(sources: list[str | Path], dst: str | Path, shares: list[float] | None = None) -> Path:
    """Write the weighted average of the weights of ``sources`` (same architecture; a "model soup",
    Wortsman et al. 2022) as a slim fp16 checkpoint; the config and training record of the first, and
    which files were averaged with what share (their digests) under ``"averaged_from"``.

    Floating-point tensors (BatchNorm statistics included) are averaged in fp32; integer ones (the
    BatchNorm batch counters) are taken from the first source."""
    if not sources:
        raise CheckpointError("average: no weights files given")
    shares = [1.0 / len(sources)] * len(sources) if shares is None else [float(s) for s in shares]
    if len(shares) != len(sources) or any(not 0 < s <= 1e6 for s in shares):  # NaN and inf fail too
        raise CheckpointError(f"average: need one positive share per weights file (finite, at most 1e6), got "
                              f"{', '.join(f'{s:g}' for s in shares[:8])}")
    total = sum(shares)
    datas = [load_checkpoint(s) for s in sources]
    first = datas[0]
    for src, d in zip(sources[1:], datas[1:]):
        if d["config"] != first["config"] or d["model"].keys() != first["model"].keys():
            raise CheckpointError(f"average: {src} has another architecture than {sources[0]}")
    weights = {}
    for key, ref in first["model"].items():
        if ref.is_floating_point():
            acc = sum(d["model"][key].float() * (w / total) for d, w in zip(datas, shares))
            weights[key] = acc.half()
            if not bool(torch.isfinite(weights[key]).all()):
                raise CheckpointError(f"average: {key} is not finite in the average (fp16); nothing was written")
        else:
            weights[key] = ref
    payload = {
        "config": dict(first["config"]),
        "model": weights,
        "metrics": {},
        "train_config": first.get("train_config", {}),
        "state": {k: v for k, v in first.get("state", {}).items() if isinstance(v, (int, float))},
        "averaged_from": [{"file": Path(s).name, "sha256": file_digest(s), "share": w / total} for s, w in zip(sources, shares)],
    }
    return save_checkpoint(dst, payload)
