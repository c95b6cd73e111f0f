"""The package version (bottom layer: the checkpoints record it, the CLI prints it)."""

__version__ = "0.1.0"
