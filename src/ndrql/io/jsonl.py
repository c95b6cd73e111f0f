"""An append-only JSON-lines log of a batch (``ndrql plan --all --jsonl FILE``) that resumes only its own files.

Each record is one line that starts with the log's signature ``{"format": "<FORMAT>"``; a file is
resumed only when it is empty or every complete line is a record of the same run (the run's key
fields equal). Anything else (notes, another program's JSON lines, another run's records) is refused
with one line and left byte for byte as it was: a file is never truncated unless it is recognised
as the log's own, and then only to drop a last line cut short by an interruption. A record that
appears twice is read once.

The file is locked (``flock``) for the whole batch, so a second batch on the same file stops at
once with one line instead of writing every record twice. An existing FIFO or device
(``/dev/null``) is written in place, without reading or locking. Each record is written with one
``write`` call and flushed to disk, so a crash leaves at most a cut last line.
Layering: standard library and :mod:`ndrql.errors`.
"""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path
from typing import Any, Callable

from ndrql.errors import NdrqlError, OutputError
from ndrql.io.atomic import make_folder

__all__ = ["BatchLog"]

MAX_LOG_BYTES = 512 * 1024 * 1024
"""Largest log resumed (about 1.5 million records)."""


def _shown(path: Path) -> str:
    text = str(path)
    return text if text.isprintable() else repr(text)


class BatchLog:
    """``with BatchLog(path, fmt, key, id_field) as log``: ``log.done`` (id -> record), ``log.append(record)``."""

    def __init__(self, path: str | os.PathLike, fmt: str, key: dict[str, Any], id_field: str,
                 to_text: Callable[[dict[str, Any]], str] = json.dumps):
        self.path = Path(path)
        self.fmt, self.key, self.id_field, self.to_text = fmt, dict(key), id_field, to_text
        self.done: dict[int, dict[str, Any]] = {}
        self._fd = -1

    # -- reading -------------------------------------------------------------------------------

    def _ours(self, line: bytes) -> bool:
        """A line that begins like one of this log's records (also when cut short)."""
        head = json.dumps({"format": self.fmt})[:-1].encode()
        return line.startswith(head)

    def _record(self, raw: bytes, number: int) -> dict[str, Any] | None:
        """The record on a complete line, or ``None`` when the line is not one of this log's records."""
        try:
            rec = json.loads(raw)
        except (ValueError, RecursionError):
            return None
        if not isinstance(rec, dict) or not isinstance(rec.get(self.id_field), int):
            return None
        if rec.get("format", self.fmt) != self.fmt or not all(k in rec for k in self.key):
            return None
        if {k: rec.get(k) for k in self.key} != self.key:
            shown = ", ".join(f"{k} {str(rec.get(k))[:60]}" for k in self.key)
            raise NdrqlError(f"{_shown(self.path)} holds results of another run ({shown}); nothing was changed, "
                             f"give another --jsonl file")
        return rec

    def _read(self, data: bytes) -> int:
        """Fill :attr:`done` from ``data``; return the length of the good prefix (a cut last line excluded)."""
        lines = data.split(b"\n")
        good = 0
        for number, raw in enumerate(lines, start=1):
            last = number == len(lines)
            if not raw.strip():
                good += len(raw) + (0 if last else 1)
                continue
            rec = self._record(raw, number)
            if rec is None:
                if last and (self.done or self._ours(raw)):  # cut short by an interruption: redone
                    break
                raise NdrqlError(f"{_shown(self.path)} is not a batch log of ndrql (line {number} is not one of "
                                 f"its records); nothing was changed, give another --jsonl file")
            self.done.setdefault(int(rec[self.id_field]), rec)  # a record twice is read once
            good += len(raw) + (0 if last else 1)
        return good

    # -- the file ------------------------------------------------------------------------------

    def __enter__(self) -> "BatchLog":
        try:
            st = os.stat(self.path)
        except (FileNotFoundError, NotADirectoryError):
            st = None
        except OSError as exc:
            raise OutputError(f"cannot write {_shown(self.path)}: {exc.strerror}") from None
        if st is not None and stat.S_ISDIR(st.st_mode):
            raise OutputError(f"cannot write {_shown(self.path)}: it is a folder")
        special = st is not None and not stat.S_ISREG(st.st_mode)
        if st is None:
            make_folder(self.path.parent)
        try:
            flags = os.O_WRONLY | os.O_APPEND if special else os.O_RDWR | os.O_APPEND | os.O_CREAT
            self._fd = os.open(self.path, flags | getattr(os, "O_CLOEXEC", 0), 0o666)
        except OSError as exc:
            raise OutputError(f"cannot write {_shown(self.path)}: {exc.strerror or type(exc).__name__}") from None
        if special:
            return self
        try:
            self._lock()
            data = self._contents()
            good = self._read(data)
            if good < len(data):  # drop the cut line so appends start on a fresh line
                os.ftruncate(self._fd, good)
        except BaseException:
            self.close()
            raise
        return self

    def _lock(self) -> None:
        try:
            import fcntl
        except ImportError:  # not on POSIX: no lock
            return
        try:
            fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise NdrqlError(f"{_shown(self.path)} is being written by another ndrql batch; wait for it to finish "
                             f"or give another --jsonl file") from None
        except OSError:
            return  # a file system without locks

    def _contents(self) -> bytes:
        size = os.fstat(self._fd).st_size
        if size > MAX_LOG_BYTES:
            raise NdrqlError(f"{_shown(self.path)} is {size:,} bytes, more than a batch log of ndrql holds; "
                             f"give another --jsonl file")
        with open(self._fd, "rb", closefd=False) as fh:
            return fh.read(MAX_LOG_BYTES + 1)

    def append(self, record: dict[str, Any]) -> None:
        """Write ``record`` (with the log's signature first) as one line, flushed to disk."""
        line = (self.to_text({"format": self.fmt, **record}) + "\n").encode()
        try:
            os.write(self._fd, line)
            try:
                os.fsync(self._fd)
            except OSError:  # a device or pipe cannot be synced
                pass
        except OSError as exc:
            raise OutputError(f"cannot write {_shown(self.path)}: {exc.strerror or type(exc).__name__}") from None

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)  # releases the lock
            self._fd = -1

    def __exit__(self, *exc: object) -> None:
        self.close()
