"""The project's own error types: the CLI turns them into one line on stderr and exit code 2."""


class NdrqlError(Exception):
    """Base class of every error ndrql raises on bad input."""


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
