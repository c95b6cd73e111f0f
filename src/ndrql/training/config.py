"""Training configuration (no torch import, so the CLI can build its flags cheaply)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class TrainConfig:
    """Everything that defines a training run (saved in every checkpoint)."""

    data: str = "../shared/data/path-planning-dataset"
    """Dataset root in its original layout."""
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
    """Mixed precision: bf16 autocast on the CPU (measured faster); on CUDA see --amp-dtype; off on MPS."""
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

    def model_config(self) -> dict:
        """Model config dict: preset + overrides + the input encoding."""
        from ndrql.model.registry import preset

        overrides = dict(self.model_overrides)
        if self.encoding:
            overrides["encoding"] = self.encoding
        return preset(self.model, **overrides)
