"""Folders shared by runs: one ndrql run at a time holds a folder (``train --run-dir``).

Layering: standard library, :mod:`ndrql.errors` and :mod:`ndrql.io.atomic` only.
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from ndrql.errors import OutputError
from ndrql.io.atomic import _error, _shown, make_folder


@contextmanager
def folder_lock(path: str | os.PathLike, what: str = "folder") -> Iterator[Path]:
    """Hold ``path`` (a folder, created if missing) for this process: a second ndrql run on it is refused
    with one :class:`OutputError` line. The lock is the kernel's (``flock`` on the folder itself, no lock
    file left behind), so it ends with the process, also on ``kill -9``; no locking where there is no
    ``fcntl``."""
    folder = make_folder(path)
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield folder
        return
    try:
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise _error(folder, exc) from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise OutputError(f"the {what} {_shown(folder)} is in use by another ndrql run; wait for it to finish "
                              f"or give another {what}") from None
        yield folder
    finally:
        os.close(fd)
