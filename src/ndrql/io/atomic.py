"""The atomic writer behind every file ndrql writes (:mod:`ndrql.io` describes the rules it follows)."""

from __future__ import annotations

import errno
import functools
import os
import stat
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any, Callable, Iterator

from ndrql.errors import OutputError
from ndrql.io import readset

_TMP_SUFFIX = ".ndrql-tmp"
"""Suffix of named temporary files (used where anonymous ones are not available)."""

_MODES = ("wb", "w")


def _shown(path: str | os.PathLike) -> str:
    """``path`` for an error message: as given, or quoted when it holds control characters."""
    text = os.fspath(path)
    return text if text.isprintable() else repr(text)


def _error(path: str | os.PathLike, exc: OSError) -> OutputError:
    return OutputError(f"cannot write {_shown(path)}: {exc.strerror or type(exc).__name__}")


def make_folder(path: str | os.PathLike) -> Path:
    """Create the folder ``path`` and its parents if missing; :class:`OutputError` if impossible."""
    folder = Path(path)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise OutputError(f"cannot create folder {_shown(folder)}: a file is in the way") from None
    except OSError as exc:
        raise OutputError(f"cannot create folder {_shown(folder)}: {exc.strerror or exc}") from None
    return folder


_AT_FDCWD = -100
_AT_SYMLINK_FOLLOW = 0x400


@functools.lru_cache(maxsize=1)
def _linkat() -> Any:
    """libc's ``linkat`` (``os.link`` does not follow the ``/proc/self/fd`` link on Linux), or ``None``."""
    try:
        import ctypes

        fn = ctypes.CDLL(None, use_errno=True).linkat
    except (ImportError, OSError, AttributeError):
        return None
    fn.argtypes = (ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_int)
    return fn


def _parent_folder(given: Path, target: Path) -> Path:
    """Create the folder ``target`` goes in; an error names the path as the user gave it."""
    try:
        return make_folder(target.parent)
    except OutputError:
        folder = given.parent
        reason = "a file is in the way" if _file_in_the_way(target.parent) else "cannot create its folder"
        raise OutputError(f"cannot write {_shown(given)}: {reason} ({_shown(folder)})") from None


def _file_in_the_way(folder: Path) -> bool:
    for part in (folder, *folder.parents):
        if part.exists():
            return not part.is_dir()
    return False


def _nearest_existing(folder: Path) -> Path:
    for part in (folder, *folder.parents):
        if part.exists():
            return part
    return Path(folder.anchor or ".")


def check_writable(path: str | os.PathLike) -> Path:
    """Fail early, writing nothing: :class:`OutputError` when ``path`` could not be written later.

    Catches a folder or socket in the way, a file where a folder should be and a folder without
    write permission; a command calls it for its output flags before the long work starts.
    """
    given = Path(path)
    target, st, direct = _inspect(given)
    if direct:
        return given  # a FIFO or device: written directly
    folder = _nearest_existing(target.parent)
    if not folder.is_dir():
        raise OutputError(f"cannot write {_shown(given)}: a file is in the way ({_shown(given.parent)})")
    if not os.access(folder, os.W_OK | os.X_OK, effective_ids=os.access in os.supports_effective_ids):
        raise OutputError(f"cannot write {_shown(given)}: Permission denied")
    return given


def _anonymous_supported() -> bool:
    """Anonymous temporary files: Linux ``O_TMPFILE``, named later through ``/proc/self/fd``."""
    return hasattr(os, "O_TMPFILE") and os.path.isdir("/proc/self/fd") and _linkat() is not None


def _temp_name(folder: Path, name: str) -> Path:
    """``.NAME.PID.RANDOM.ndrql-tmp.EXT``: hidden, traceable to its writer, same extension as the target."""
    return folder / f".{name[:180]}.{os.getpid()}.{os.urandom(4).hex()}{_TMP_SUFFIX}{Path(name).suffix[:16]}"


def _open_temp(folder: Path, name: str) -> tuple[int, Path | None]:
    """A writable descriptor for the new contents and its name (``None`` while anonymous)."""
    flags = os.O_WRONLY | getattr(os, "O_CLOEXEC", 0)
    if _anonymous_supported():
        try:
            return os.open(folder, flags | os.O_TMPFILE, 0o666), None
        except OSError as exc:  # the filesystem has no O_TMPFILE: use a named file
            if exc.errno not in (errno.EOPNOTSUPP, errno.EISDIR, errno.EINVAL):
                raise
    while True:
        tmp = _temp_name(folder, name)
        try:
            return os.open(tmp, flags | os.O_CREAT | os.O_EXCL, 0o666), tmp
        except FileExistsError:
            continue


def _link_anonymous(fd: int, folder: Path, name: str) -> Path:
    """Give the anonymous file ``fd`` a temporary name in ``folder`` (to rename it over the target)."""
    import ctypes

    linkat = _linkat()
    source = f"/proc/self/fd/{fd}".encode()
    while True:
        tmp = _temp_name(folder, name)
        if linkat(_AT_FDCWD, source, _AT_FDCWD, os.fsencode(tmp), _AT_SYMLINK_FOLLOW) == 0:
            return tmp
        code = ctypes.get_errno()
        if code != errno.EEXIST:
            raise OSError(code, os.strerror(code), str(tmp))


def _sweep_stale(folder: Path, name: str) -> None:
    """Remove temporary files of ``name`` left by processes that no longer run (``kill -9``)."""
    prefix = f".{name[:180]}."
    try:
        entries = [e for e in os.listdir(folder) if e.startswith(prefix) and _TMP_SUFFIX in e]
    except OSError:
        return
    for entry in entries:
        try:
            pid = int(entry[len(prefix):].split(".")[0])
            if pid == os.getpid():
                continue
            os.kill(pid, 0)
        except ProcessLookupError:
            try:
                os.unlink(folder / entry)
            except OSError:
                pass
        except (ValueError, PermissionError, OverflowError):
            continue


def _fsync_folder(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _open_kwargs(mode: str) -> dict[str, Any]:
    return {} if "b" in mode else {"encoding": "utf-8", "newline": ""}


def _write_direct(given: Path, target: Path, write_fn: Callable[[IO], Any], mode: str) -> None:
    """Write into an existing non-regular file (FIFO, device) without replacing it."""
    try:
        with open(target, mode, **_open_kwargs(mode)) as fh:
            write_fn(fh)
    except BrokenPipeError:
        raise  # `--json /dev/stdout | head`: the reader left, the CLI stops quietly (exit 141)
    except OSError as exc:
        raise _error(given, exc) from None


def _replace(given: Path, target: Path, write_fn: Callable[[IO], Any], mode: str, keep_mode: int | None) -> None:
    """Write a new file beside ``target`` and rename it over ``target``; no debris on any failure."""
    folder, name = target.parent, target.name
    fd, tmp = -1, None
    try:
        fd, tmp = _open_temp(folder, name)
        with os.fdopen(fd, mode, closefd=False, **_open_kwargs(mode)) as fh:
            write_fn(fh)
            fh.flush()
        if keep_mode is not None:
            os.fchmod(fd, keep_mode)
        os.fsync(fd)
        if tmp is None:
            tmp = _link_anonymous(fd, folder, name)
        else:
            _sweep_stale(folder, name)
        _recheck(target)
        os.replace(tmp, target)
        tmp = None
    except BaseException as exc:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        if isinstance(exc, OSError):
            raise _error(given, exc) from None
        raise
    finally:
        if fd >= 0:
            os.close(fd)
    _fsync_folder(folder)


def atomic_write(path: str | os.PathLike, write_fn: Callable[[IO], Any], *, mode: str = "wb") -> Path:
    """Write a file by calling ``write_fn(fh)`` on an open file object; return ``path`` as given.

    ``mode`` is ``"wb"`` (bytes) or ``"w"`` (UTF-8 text). Regular files are replaced atomically,
    FIFOs and devices written directly, new files created with the umask's
    permissions, parent folders created (module docstring); a symlink at the name, one of the run's
    inputs and the package's own files are refused (:func:`_inspect`). An ``OSError`` becomes one
    :class:`OutputError` line; any other exception from ``write_fn`` propagates unchanged. Either
    way no temporary file is left behind and the old contents stay in place.
    """
    if mode not in _MODES:
        raise ValueError(f"mode must be one of {', '.join(_MODES)}, got {mode!r}")
    given = Path(path)
    target, st, direct = _inspect(given)
    if direct:
        _write_direct(given, target, write_fn, mode)
        return given
    _parent_folder(given, target)
    _replace(given, target, write_fn, mode, stat.S_IMODE(st.st_mode) if st is not None else None)
    return given


_MAGIC_FOLDERS = ("/dev/", "/proc/")
"""Links here are the kernel's (``/dev/stdout``, ``/proc/self/fd/N``): followed and written in place."""


def _inspect(given: Path) -> tuple[Path, os.stat_result | None, bool]:
    """The name to write, its status (``None`` if it does not exist yet) and whether to write in place.

    In place: an existing FIFO, device or other non-regular file, and a kernel link (``/dev/stdout``
    redirected to a file). Refused, each as one :class:`OutputError` line: a folder or socket in the
    way, any other symbolic link at the name (a rename would replace it, so ndrql never writes through
    one), one of the run's inputs or a file the package ships (:mod:`ndrql.io.readset`).
    """
    try:
        st: os.stat_result | None = os.lstat(given)
    except (FileNotFoundError, NotADirectoryError):  # a missing folder or a file in the way: make_folder says
        st = None
    except OSError as exc:
        raise _error(given, exc) from None
    link = st is not None and stat.S_ISLNK(st.st_mode)
    if link:
        try:
            st = os.stat(given)
        except (FileNotFoundError, NotADirectoryError):
            st = None
        except OSError as exc:
            raise _error(given, exc) from None
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise OutputError(f"cannot write {_shown(given)}: it is a folder")
    if st is not None and stat.S_ISSOCK(st.st_mode):
        raise OutputError(f"cannot write {_shown(given)}: it is a socket")
    if st is not None and not stat.S_ISREG(st.st_mode):
        return given, st, True
    if link and not os.path.abspath(given).startswith(_MAGIC_FOLDERS):
        raise OutputError(f"cannot write {_shown(given)}: it is a symbolic link (to {_shown(_readlink(given))}); "
                          f"ndrql never writes through one: nothing was written, remove the link or give the file itself")
    _claim(given, st)
    return given, st, link


def _readlink(path: Path) -> str:
    try:
        return os.readlink(path)
    except OSError:
        return "?"


def _claim(given: Path, st: os.stat_result | None) -> None:
    """:class:`OutputError` when ``given`` is one of the run's inputs or a file the package ships."""
    reason = readset.refusal(given, st)
    if reason:
        raise OutputError(f"cannot write {_shown(given)}: {reason}; nothing was written, give another name")


def _recheck(given: Path) -> None:
    """Just before the rename: a symlink planted at the name while the run worked is refused, never followed."""
    try:
        st = os.lstat(given)
    except OSError:
        return
    if stat.S_ISLNK(st.st_mode):
        raise OutputError(f"cannot write {_shown(given)}: it became a symbolic link (to {_shown(_readlink(given))}) "
                          f"while ndrql worked; nothing was written")
    _claim(given, st)


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary file name to write to (for libraries that only write to file names).

    The same rules as :func:`atomic_write`: on success the temporary file replaces the target (or,
    for a FIFO or device, is copied into it); on any error it is removed and the target left as it
    was. The temporary name ends with the target's extension.
    """
    import shutil
    import tempfile

    given = Path(path)
    target, st, direct = _inspect(given)
    if direct:
        with tempfile.TemporaryDirectory(prefix="ndrql-") as scratch:
            tmp = Path(scratch) / f"out{target.suffix[:16]}"
            yield tmp

            def copy(fh: IO) -> None:
                with open(tmp, "rb") as src:
                    shutil.copyfileobj(src, fh)

            _write_direct(given, target, copy, "wb")
        return
    folder = _parent_folder(given, target)
    _sweep_stale(folder, target.name)
    tmp = None
    try:
        while tmp is None:
            candidate = _temp_name(folder, target.name)
            try:
                os.close(os.open(candidate, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
                tmp = candidate
            except FileExistsError:
                continue
        yield tmp
        if st is not None:
            os.chmod(tmp, stat.S_IMODE(st.st_mode))
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        _recheck(target)
        os.replace(tmp, target)
        tmp = None
    except OSError as exc:
        raise _error(given, exc) from None
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
    _fsync_folder(folder)


def write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` (:func:`atomic_write`)."""
    return atomic_write(path, lambda fh: fh.write(data))


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` as UTF-8 (:func:`atomic_write`)."""
    return atomic_write(path, lambda fh: fh.write(text), mode="w")


def open_log(path: str | os.PathLike) -> IO[str]:
    """``path`` opened to append UTF-8 lines (a training log), under the writer's rules: never through a
    symlink (``O_NOFOLLOW``), never one of the run's inputs or the package's files; parent folders created."""
    given = Path(path)
    _, st, direct = _inspect(given)
    if not direct:
        _parent_folder(given, given)
    try:
        fd = os.open(given, os.O_WRONLY | os.O_APPEND | os.O_CREAT | getattr(os, "O_CLOEXEC", 0)
                     | (0 if direct else getattr(os, "O_NOFOLLOW", 0)), 0o666)
    except OSError as exc:
        raise _error(given, exc) from None
    return os.fdopen(fd, "a", encoding="utf-8")
