"""Training configuration (no torch import, so the CLI can build its flags cheaply)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ndrql.limits import BOUNDS, SEED_LIMIT, check_bound

#: What the ranking term of the distance-head loss compares (:func:`ndrql.training.losses.distance_loss`):
#: the raw predicted distances (v5), or the mean of that and the same loss on the distances as Eq. 6
#: takes them, the detour snapped to an even number of moves (:func:`ndrql.training.losses.soft_snap`);
#: ``+moves`` adds the greedy move's listwise loss (:func:`ndrql.training.losses.greedy_move_loss`).
RANK_ON = ("raw", "raw+snapped", "raw+snapped+moves")

#: (field, lowest, highest) of the numeric training fields; ``None`` = unbounded on that side.
_RANGES: tuple[tuple[str, float | None, float | None], ...] = (
    ("epochs", 1, 100_000), ("batch_size", 1, 65_536), ("warmup_steps", 0, None), ("seed", 0, SEED_LIMIT - 1),
    ("loader_workers", 0, 256), ("threads", 0, 4096), ("max_steps", 0, None),
)


def check_train_config(cfg: "TrainConfig") -> None:
    """``ValueError`` (one line naming the flag) for a value no run can use: a batch of 0, no epochs,
    a validation fraction outside (0, 1), a negative or non-finite rate."""
    def bad(name: str, rule: str, value: object) -> ValueError:
        return ValueError(f"--{name.replace('_', '-')} must be {rule}, got {str(value)[:40]}")

    for name, lo, hi in _RANGES:
        value = getattr(cfg, name)
        if not isinstance(value, int) or isinstance(value, bool):
            raise bad(name, "an integer", value)
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            rule = f">= {lo}" if hi is None else f"in {lo}..{hi}"
            raise bad(name, rule, value)
    for name, positive in (("lr", True), ("weight_decay", False), ("checkpoint_minutes", True)):
        value = getattr(cfg, name)
        if not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0 or (positive and value == 0):
            raise bad(name, "a finite number > 0" if positive else "a finite number >= 0", value)
    if not (isinstance(cfg.val_fraction, (int, float)) and 0 < cfg.val_fraction < 1):
        raise bad("val_fraction", "between 0 and 1 (exclusive)", cfg.val_fraction)
    if not isinstance(cfg.model_overrides, dict):
        raise bad("model_overrides", "a JSON object", cfg.model_overrides)
    if cfg.distance_head and cfg.input_mode != "grid":
        raise ValueError("--distance-head needs --input-mode grid (its labels are the planning grid's goal distances)")
    parts = [p.strip() for p in str(cfg.train_only).split(",") if p.strip()]
    unknown = [p for p in parts if p not in TRAIN_PARTS]
    if unknown:
        raise ValueError(f"--train-only: unknown part {', '.join(unknown)}; valid: {', '.join(TRAIN_PARTS)}")
    if cfg.distance_decoder and not cfg.distance_head:
        raise ValueError("--distance-decoder needs --distance-head")
    uw = check_bound(cfg.unknown_weight, BOUNDS["train --unknown-weight"], "--unknown-weight")  # the flag's own range
    if uw > 0 and "unknown" not in str(cfg.encoding):
        raise ValueError("--unknown-weight needs an encoding with the unknown channel (--encoding point+unknown)")
    if cfg.distance_rank not in RANK_ON:
        raise ValueError(f"--distance-rank must be one of {', '.join(RANK_ON)}, got {str(cfg.distance_rank)[:40]}")
    if cfg.view != "native":
        from ndrql.dataset.views import GridView  # lazy: the dataset layer

        GridView.parse(cfg.view)
        if cfg.input_mode != "grid":
            raise ValueError("--view needs --input-mode grid (a view says how the planning grid is drawn)")
    if "distance" in parts and not cfg.distance_head:
        raise ValueError("--train-only distance needs --distance-head")


#: Top-level parts of an NDR network that ``--train-only`` may name.
TRAIN_PARTS = ("backbone", "context", "fuse4", "fuse3", "region_head", "guideline", "distance")


@dataclass(frozen=True)
class TrainConfig:
    """Everything that defines a training run (saved in every checkpoint)."""

    data: str = "path-planning-dataset"
    """Dataset root in its original layout; ndrql train uses $NDRQL_DATASET or a path-planning-dataset folder it finds when not given."""
    model: str = "ndr-stdc1-half"
    """Model preset (ndrql.model.registry.PRESETS)."""
    model_overrides: dict = field(default_factory=dict)
    """Config fields overriding the preset (e.g. {'unet_base': 8})."""
    encoding: str = ""
    """Input encoding of start and goal (ndrql.dataset.encodings); empty = the preset's own (NDR: point, RGP: rgb)."""
    epochs: int = 7
    """Epochs of the cosine schedule."""
    batch_size: int = 16
    """Samples per optimisation step and process (global batch = batch_size x world size under DDP)."""
    lr: float = 2e-3
    """Peak AdamW learning rate."""
    scale_lr: bool = False
    """Linear scaling rule under DDP: peak lr x world size (off: --lr is used as given)."""
    weight_decay: float = 1e-4
    """AdamW weight decay."""
    warmup_steps: int = 300
    """Linear warm-up steps before the cosine decay."""
    val_fraction: float = 0.05
    """Fraction of TRAIN's distinct maps held out for validation (never a SEEN map)."""
    seed: int = 0
    """Seed of the split, the data order and the augmentation."""
    augment: bool = True
    """Dihedral augmentation of map, points and labels together."""
    bf16: bool = True
    """Mixed precision: bf16 autocast on a CPU with native bf16 (AVX512-BF16 or AMX; fp32 otherwise, where emulated bf16 is several times slower); on CUDA see --amp-dtype; off on MPS."""
    device: str = "auto"
    """Device: auto (CUDA when available, else CPU), cpu, cuda or mps."""
    amp_dtype: str = "auto"
    """Autocast dtype on CUDA: auto (bf16 where supported, else fp16), bf16, or fp16 (with a GradScaler)."""
    loader_workers: int = 2
    """DataLoader worker processes building batches into pinned memory on GPU (the CPU path builds them inline)."""
    sync_bn: bool = False
    """BatchNorm statistics over the global batch under DDP (SyncBatchNorm; CUDA only). Off: per-process batch."""
    threads: int = 0
    """Torch intra-op threads (0 = all cores)."""
    checkpoint_minutes: float = 5.0
    """Minutes between mid-epoch checkpoints."""
    max_steps: int = 0
    """Stop after this many optimisation steps in this invocation (0 = no limit; for tests)."""
    sources: str = ""
    """Weighted training sources, e.g. paper:1,DIR:3 (DIR from ndrql data generate); empty = the paper's dataset alone."""
    input_mode: str = "map"
    """What the model sees: map (the map at about 4 px per planning cell) or grid (the planning grid at 4 px per cell)."""
    grid_sizes: str = "50"
    """Planning-grid sizes to train for (with --sources), e.g. 50,100: inputs of about 4 x size px; 8-256, or up to 512 under a --view that bounds the input (cap/coarse)."""
    steps_per_epoch: int = 0
    """Optimisation steps per epoch with --sources (0 = as many as one pass over the paper's training split)."""
    val_per_source: int = 64
    """Held-out validation samples per source with --sources."""
    exclude_families: str = ""
    """Families of generated sources left out of training and validation, e.g. maze,office (leave-families-out runs)."""
    init_weights: str = ""
    """Warm start: weights (checkpoint file) to start from instead of random initialisation."""
    distance_head: bool = False
    """Also train the goal-distance output (grid mode; a warm start without one initialises it anew)."""
    distance_decoder: str = ""
    """Kind of distance head with --distance-head: coarse (v4) or skips (decoded with the walls at strides 4 and 2); empty: the model preset's."""
    distance_rank: str = "raw"
    """Ranking term of the distance-head loss: raw (v5), raw+snapped (also ranks the detours as Eq. 6 snaps them; v6) or raw+snapped+moves (also scores each cell's greedy move; training.losses.distance_loss)."""
    unknown_weight: float = 0.0
    """Loss weight 1 + W on the pixels unknown to the planner (BCE and distance terms; needs the unknown channel)."""
    view: str = "native"
    """How the model sees planning grids in grid mode (ndrql.dataset.views.GridView): native (4 px per cell), cap:PX, coarse:CELLS (above CELLS, cells merged so the input stays at most 4 x CELLS px) or walls:CELLS (merged, thin walls kept); saved in the model's config."""
    train_only: str = ""
    """Train only these parts of the model (comma-separated top-level modules, e.g. distance); the rest keeps its weights and BatchNorm statistics."""

    def __post_init__(self) -> None:
        check_train_config(self)

    def model_config(self) -> dict:
        """Model config dict: preset + overrides + the input encoding."""
        from ndrql.model.registry import preset  # lazy: loads torch

        overrides = dict(self.model_overrides)
        if self.encoding:
            from ndrql.dataset.encodings import encoding_channels  # lazy: the dataset layer

            overrides["encoding"] = self.encoding
            if encoding_channels(self.encoding) != 3:
                overrides["in_channels"] = encoding_channels(self.encoding)
        if self.input_mode != "map":
            overrides["input_mode"] = self.input_mode
        if self.distance_head:
            overrides["distance_head"] = True
        if self.distance_decoder:
            overrides["distance_decoder"] = self.distance_decoder
        if self.view != "native":
            overrides["view"] = self.view
        return preset(self.model, **overrides)
