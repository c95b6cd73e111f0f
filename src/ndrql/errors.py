"""The project's own error types: the CLI turns them into one line on stderr and exit code 2.

:func:`brief` formats a value from a file or the command line for such a line, bounded in length;
:func:`require_torch` says what to install when a torch-only feature runs without torch.
"""


def brief(value: object) -> str:
    """``value`` for an error message: short scalars as written, anything else described, never unbounded.

    Containers are never formatted (a 600-byte YAML alias bomb is tiny as parsed, gigabytes as text),
    long strings are cut at 40 characters, huge integers are given by their size.
    """
    if value is None or isinstance(value, (bool, float)):
        return repr(value)
    if isinstance(value, int):
        return repr(value) if abs(value) < 10**15 else f"a {value.bit_length()}-bit integer"
    if isinstance(value, str):
        return repr(value) if len(value) <= 40 else repr(value[:40]) + "..."
    if isinstance(value, (list, tuple)):
        return f"a list of {len(value)} items"
    if isinstance(value, dict):
        return f"a mapping of {len(value)} keys"
    return f"a {type(value).__name__}"


class NdrqlError(Exception):
    """Base class of every error ndrql raises on bad input."""


class NdrqlWarning(UserWarning):
    """Base class of ndrql's own warnings (filter them with ``warnings.filterwarnings(..., category=NdrqlWarning)``)."""


class FallbackWarning(NdrqlWarning):
    """The method asked for did not run: the model's prediction was uninformative and the fallback ran instead."""


class BoundError(NdrqlError, ValueError):
    """A number outside its declared range (:data:`ndrql.limits.BOUNDS`); also a ``ValueError``."""


class ArgumentError(NdrqlError, TypeError):
    """An API function called with an unknown keyword, one given twice or too many; also a ``TypeError``."""


class MapFormatError(NdrqlError):
    """A map file is missing, unreadable, corrupt, or of an unsupported format."""


class PointError(NdrqlError):
    """A start or goal is off the map, on an obstacle, or otherwise unusable."""


class NoPathError(NdrqlError):
    """Start and goal are not connected."""


class CheckpointError(NdrqlError):
    """A model checkpoint is missing, corrupt, or from another architecture or version."""


class DatasetError(NdrqlError):
    """The dataset directory is missing or does not have the expected layout."""


class OutputError(NdrqlError):
    """An output file cannot be written: unwritable or missing folder, a directory in the way, disk full."""


class MissingDependency(NdrqlError):
    """An optional dependency is not installed for what was asked (torch for training, evaluation, export)."""


#: What to install for the torch-only commands (train, eval, export, the model tables, ``--backend torch``).
TRAIN_INSTALL = "pip install 'ndrql[train]'"


def torch_missing(what: str) -> MissingDependency:
    """The one-line error for ``what`` when torch is not installed."""
    return MissingDependency(f"{what} needs torch, which is not installed: {TRAIN_INSTALL}")


def require_torch(what: str) -> None:
    """Raise :func:`torch_missing` for ``what`` unless torch imports (planning with the shipped models never calls this)."""
    try:
        import torch  # noqa: F401  # lazy: torch is optional
    except ImportError:
        raise torch_missing(what) from None
