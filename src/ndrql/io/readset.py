"""The run's input set: every file a run reads, which the writer (:mod:`ndrql.io.atomic`) never replaces.

Readers call :func:`note_input` on the files they open (maps and a ROS map's image, ``.scen`` files,
checkpoints and the weights a name resolves to, presets, ONNX graphs, cached exports); the CLI opens
one :func:`run_inputs` scope per command, so the set is the command's own. A run's own state (the
``last.pt`` a training resumes from and rewrites) is read with ``note=False``. Outside a scope (the
API in a long-lived process) nothing is recorded. Everything the package ships (its folder: the
shipped weights, their ONNX sidecars, presets, the bundled map, the code) is always an input; the
maintainers' tools that refresh those files set ``NDRQL_WRITE_PACKAGE=1``.

:func:`refusal` says why a path may not be written (or ``None``); files are compared by device and
inode (hard links count) and by resolved path. Layering: standard library only.
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

__all__ = ["PACKAGE_ROOT", "WRITE_PACKAGE_ENV", "in_package", "note_input", "refusal", "run_inputs"]

PACKAGE_ROOT = Path(__file__).resolve().parents[1]
"""The installed ``ndrql`` package: every file in it is an input of every run."""
WRITE_PACKAGE_ENV = "NDRQL_WRITE_PACKAGE"
"""Set to ``1`` by the maintainers' tools that refresh the shipped weights, graphs and presets."""

_scope: list[dict[object, str]] = []
"""The open scopes' input sets (the innermost last): (device, inode) and resolved path -> what it is."""
_owner: list[int] = [0]
"""The process that opened the scope (a forked worker has its own run: a training child writes its state)."""


def _current() -> dict[object, str] | None:
    return _scope[-1] if _scope and _owner[0] == os.getpid() else None


@contextmanager
def run_inputs() -> Iterator[None]:
    """Record the files read inside the block as the run's inputs (nested blocks share the outer set)."""
    _scope.append(_scope[-1] if _scope else {})
    _owner[0] = os.getpid()
    try:
        yield
    finally:
        _scope.pop()


def note_input(path: str | os.PathLike, what: str = "an input") -> None:
    """Record ``path`` (a file this run reads) as one of its inputs; nothing outside :func:`run_inputs`."""
    found = _current()
    if found is None:
        return
    try:
        st = os.stat(path)
        found.setdefault((st.st_dev, st.st_ino), f"{what} {os.fspath(path)}")
        found.setdefault(os.path.realpath(path), f"{what} {os.fspath(path)}")
    except (OSError, ValueError, TypeError):
        return


def _in_package(real: str) -> bool:
    return os.environ.get(WRITE_PACKAGE_ENV) != "1" and (real == str(PACKAGE_ROOT)
                                                          or real.startswith(str(PACKAGE_ROOT) + os.sep))


def in_package(path: str | os.PathLike) -> bool:
    """Whether ``path`` (resolved) is the installed package's folder or inside it (and writing there is not on)."""
    return _in_package(os.path.realpath(path))


def refusal(path: str | os.PathLike, st: os.stat_result | None) -> str | None:
    """Why ``path`` (a name about to be replaced; ``st`` its status, ``None`` when missing) may not be
    written: one of the run's inputs or a file the package ships; ``None`` when it may."""
    text = os.fspath(path)
    real = os.path.join(os.path.realpath(os.path.dirname(text) or "."), os.path.basename(text))
    if _in_package(real):
        return (f"it is inside the installed ndrql package ({PACKAGE_ROOT}); writing there would break every "
                f"later run")
    found = _current()
    if found is None:
        return None
    what = found.get(real) or (found.get((st.st_dev, st.st_ino)) if st is not None else None)
    return f"it is one of the inputs ({what}), which this run reads; writing it would destroy it" if what else None
