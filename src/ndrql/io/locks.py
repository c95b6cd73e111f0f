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


LOCK_NAME = ".ndrql.lock"
"""The lock file :func:`folder_lock` keeps in a folder (it holds the owner's process id)."""


@contextmanager
def folder_lock(path: str | os.PathLike, what: str = "folder") -> Iterator[Path]:
    """Hold ``path`` (a folder, created if missing) for this process: a second ndrql run on it is refused
    with one :class:`OutputError` line naming the process that holds it. The lock is the kernel's
    (``flock``), so it ends with the process, also on ``kill -9``; no locking where there is no ``fcntl``."""
    folder = make_folder(path)
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield folder
        return
    lock = folder / LOCK_NAME
    try:
        fd = os.open(lock, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NOFOLLOW", 0), 0o666)
    except OSError as exc:
        raise _error(lock, exc) from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            owner = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
            raise OutputError(f"the {what} {_shown(folder)} is in use by another ndrql run (process {owner}); wait for "
                              f"it to finish or give another {what}") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield folder
    finally:
        os.close(fd)
