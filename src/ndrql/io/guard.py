"""Outputs that cannot destroy inputs: every path a command writes, checked against every path it reads.

A command lists what it will write (:class:`Output`: a file, or a folder and the names it writes
there) and what it reads (:class:`Input`: a file, or a folder of files), and calls
:func:`check_outputs` before any work starts. Paths are compared after resolving symlinks and
``..`` (and, for files that exist, by device and inode, so hard links count too). Refused, each
as one :class:`~ndrql.errors.OutputError` line, with nothing written:

- an output that is one of the inputs (``--json map.png``), or a file inside an input folder
  that already exists (a dataset's own file);
- an output folder that would receive a file under the name of an input (``--out`` holding the
  map as ``region.png``), or, when the command does not say which names it writes, any input
  inside it;
- two outputs on one file (``--json X --png X``), or an output inside an output folder under a
  name that folder receives;
- ``-`` for an output that cannot go to standard output (``--png -`` would write a file named
  ``-``), or two outputs on standard output;
- an output that could not be written anyway (:func:`ndrql.io.atomic.check_writable`).

An existing FIFO or character device (``/dev/null``) is written in place and never replaced, so it
is exempt from the comparisons. Layering: standard library and :mod:`ndrql.errors` only.
"""

from __future__ import annotations

import os
import stat
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

from ndrql.errors import OutputError
from ndrql.io.atomic import check_writable
from ndrql.io.readset import in_package

__all__ = ["Input", "Output", "check_outputs", "shown"]


@dataclass(frozen=True)
class Output:
    """A path a command writes."""

    flag: str
    """How the user gave it (``--json``, ``OUTPUT``), for the message."""
    path: str
    folder: bool = False
    """A folder the command writes files into (``--out DIR``)."""
    names: tuple[str, ...] | None = None
    """Folder outputs: the file names written in it (``None``: not known, so no input may lie inside)."""
    stdout: bool = False
    """``-`` means standard output."""


@dataclass(frozen=True)
class Input:
    """A path a command reads."""

    flag: str
    path: str
    folder: bool = False
    """A folder of inputs (a dataset): no output may replace a file inside it."""


def shown(path: str | os.PathLike) -> str:
    """``path`` for a message: as given, or quoted with escapes when it holds control characters."""
    text = os.fspath(path)
    return text if text.isprintable() else repr(text)


@dataclass(frozen=True)
class _Where:
    real: Path
    inode: tuple[int, int] | None
    special: bool
    """An existing FIFO, device or other non-regular, non-folder file: written in place."""


def _where(path: str) -> _Where:
    real = Path(os.path.realpath(path))
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return _Where(real, None, False)
    special = not (stat.S_ISREG(st.st_mode) or stat.S_ISDIR(st.st_mode))
    return _Where(real, (st.st_dev, st.st_ino), special)


def _same(a: _Where, b: _Where) -> bool:
    return a.real == b.real or (a.inode is not None and a.inode == b.inode)


def _inside(child: Path, folder: Path) -> bool:
    return child != folder and folder in child.parents


def _clash(out: Output, what: str) -> OutputError:
    return OutputError(f"{out.flag} {shown(out.path)} {what}; nothing was written, give another "
                       f"{'folder' if out.folder else 'file'}")


def _check_one(out: Output) -> None:
    if out.path == "-":
        if not out.stdout:
            raise OutputError(f"{out.flag} cannot write to standard output ('-'); give a file name")
        if sys.stdout is None:  # closed (`>&-`): said now, not after the work
            raise OutputError(f"standard output is closed; give {out.flag} a file name")
        return
    if not out.path:
        raise OutputError(f"{out.flag} needs a file name, got an empty one")
    if "\0" in out.path:
        raise OutputError(f"{out.flag} {shown(out.path)}: a file name cannot hold a NUL character")
    if not out.folder:
        check_writable(out.path)
        return
    target = Path(out.path)
    if in_package(target):
        raise _clash(out, "is inside the installed ndrql package; writing there would break every later run")
    if target.exists() and not target.is_dir():
        raise OutputError(f"{out.flag} {shown(out.path)}: cannot create folder {shown(out.path)}: a file is in the way")
    existing = next((p for p in (target, *target.parents) if p.exists()), Path("."))
    if not existing.is_dir():
        raise OutputError(f"{out.flag} {shown(out.path)}: a file is in the way ({shown(existing)})")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise OutputError(f"{out.flag} {shown(out.path)}: cannot write there (Permission denied)")
    for name in out.names or ():  # a name the folder receives, planted as a link: refused now, not after the work
        if (target / name).is_symlink():
            raise _clash(out, f"holds {name} as a symbolic link; ndrql never writes through one")


def _folder_receives(folder: Output, where: _Where, target: _Where) -> bool:
    """Whether writing into ``folder`` (at ``where``) may replace the file at ``target``."""
    if folder.names is None:
        return _inside(target.real, where.real)
    return target.real.parent == where.real and target.real.name in folder.names


def _against_inputs(out: Output, where: _Where, inputs: Sequence[tuple[Input, _Where]]) -> None:
    for inp, iw in inputs:
        if inp.folder:
            if out.folder:
                if out.names is None and (where.real == iw.real or _inside(where.real, iw.real)
                                          or _inside(iw.real, where.real)):
                    raise _clash(out, f"overlaps the input folder {inp.flag} {shown(inp.path)}")
                for name in out.names or ():
                    target = where.real / name
                    if target.exists() and _inside(target, iw.real):
                        raise _clash(out, f"would replace {name} of the input folder {inp.flag} {shown(inp.path)}")
            elif where.inode is not None and _inside(where.real, iw.real):
                raise _clash(out, f"is a file of the input folder {inp.flag} {shown(inp.path)}: writing it would "
                                  f"destroy it")
        elif out.folder:
            if _same(where, iw):
                raise _clash(out, f"is one of the inputs ({inp.flag} {shown(inp.path)})")
            if _folder_receives(out, where, iw):
                raise _clash(out, f"would receive a file named like the input {inp.flag} {shown(inp.path)}, "
                                  f"replacing it")
        elif _same(where, iw):
            raise _clash(out, f"is one of the inputs ({inp.flag} {shown(inp.path)}): writing it would destroy it")


def _against_outputs(checked: Sequence[tuple[Output, _Where]]) -> None:
    for i, (a, aw) in enumerate(checked):
        for b, bw in checked[i + 1:]:
            if a.folder and b.folder:
                same = _same(aw, bw)
            elif a.folder or b.folder:
                (f, fw), (o, ow) = ((a, aw), (b, bw)) if a.folder else ((b, bw), (a, aw))
                same = _folder_receives(f, fw, ow)
            else:
                same = _same(aw, bw)
            if same:
                raise OutputError(f"{a.flag} and {b.flag} both write {shown(b.path)}: one would overwrite the "
                                  f"other; nothing was written, give each its own name")


def check_outputs(outputs: Iterable[Output], inputs: Iterable[Input] = ()) -> None:
    """:class:`OutputError` (one line, nothing written) when an output could destroy an input or another output.

    Also fails early when an output could not be written at all; ``None`` paths are skipped by the
    callers (pass only what was given).
    """
    outs = [o for o in outputs if o.path is not None]
    on_stdout = [o.flag for o in outs if o.path == "-" and o.stdout]
    if len(on_stdout) > 1:
        raise OutputError(f"{' and '.join(on_stdout)} cannot both write to standard output ('-')")
    for out in outs:
        _check_one(out)
    ins = [(i, _where(i.path)) for i in inputs if i.path]
    checked: list[tuple[Output, _Where]] = []
    for out in outs:
        if out.path == "-":
            continue
        where = _where(out.path)
        if where.special:
            continue  # a FIFO or device: written in place, never replaced
        _against_inputs(out, where, ins)
        checked.append((out, where))
    _against_outputs(checked)
