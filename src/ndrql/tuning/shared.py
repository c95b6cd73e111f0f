"""Several ``ndrql tune`` processes on one study storage (the documented ``--storage`` use).

Two processes that open a new SQLite file or create the same study at once race: one creates the tables or
the study, the other gets ``IntegrityError``, ``DuplicatedStudyError`` or "database is locked". Such an
error is transient: :func:`retry_shared` tries again (the second attempt loads what the first created), and
:func:`engine_kwargs` lets SQLite wait for a writer instead of failing at once.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable, TypeVar

from ndrql.io import make_folder

T = TypeVar("T")

#: Seconds SQLite waits for another process's write before "database is locked".
SQLITE_TIMEOUT = 60.0
_TRANSIENT = ("IntegrityError", "DuplicatedStudyError", "OperationalError")


def transient(exc: BaseException) -> bool:
    """Whether ``exc`` is another process creating the same tables or study, or holding the database."""
    seen: BaseException | None = exc
    for _ in range(8):
        if seen is None:
            return False
        if type(seen).__name__ in _TRANSIENT or "database is locked" in str(seen):
            return True
        seen = seen.__cause__ or seen.__context__
    return False


def retry_shared(make: Callable[[], T], tries: int = 8, pause: float = 0.25) -> T:
    """``make()``, tried again after a transient error (:func:`transient`), with a growing pause."""
    for attempt in range(tries):
        try:
            return make()
        except Exception as exc:  # noqa: BLE001 - SQLAlchemy's and Optuna's error types, sorted by transient()
            if attempt == tries - 1 or not transient(exc):
                raise
            time.sleep(pause * (attempt + 1))
    raise AssertionError("unreachable")


def engine_kwargs(url: str) -> dict:
    """SQLAlchemy engine options for ``url``: SQLite waits :data:`SQLITE_TIMEOUT` s for a lock."""
    return {"connect_args": {"timeout": SQLITE_TIMEOUT}} if url.startswith("sqlite:") else {}


def default_storage(out_dir: str | Path) -> str:
    """SQLite file ``<out_dir>/studies.db`` as an Optuna storage URL (the folder is created)."""
    folder = make_folder(out_dir)
    return f"sqlite:///{(folder / 'studies.db').resolve()}"
