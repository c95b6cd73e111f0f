"""Which compiled kernels run: the C extension built at install time, or numba. The one place that decides.

ndrql's inner loops (Q-learning, the 8-connected A*, the segment tests) exist twice, with
bit-identical results:

- ``ndrql.maps._kernels``, C99 compiled ahead of time when the package is installed (``setup.py``):
  nothing compiles at run time, and neither numba nor scipy is imported;
- the numba kernels (:mod:`ndrql.planning.kernel`, :mod:`ndrql.maps.astar_kernel`,
  :mod:`ndrql.maps.lines_kernel`): the reference, and the fallback when the extension was not built
  (no C compiler at install time). numba compiles them on first use and caches the machine code on disk.

The environment variable ``NDRQL_KERNELS`` chooses: ``auto`` (the default: C when the extension
imports, else numba), ``c`` (the extension, an error when it is missing) or ``numba``. It is read on
every call, so a test or a benchmark can switch within one process.
"""

from __future__ import annotations

import os
from types import ModuleType

from ndrql.errors import NdrqlError

#: The environment variable that chooses the kernels: ``auto``, ``c`` or ``numba``.
KERNELS_ENV = "NDRQL_KERNELS"
CHOICES = ("auto", "c", "numba")

_loaded: list[ModuleType | None] = []  # the import of the extension, tried once per process


def extension() -> ModuleType | None:
    """The C extension ``ndrql.maps._kernels``, or None when it was not built (tried once)."""
    if not _loaded:
        try:
            from ndrql.maps import _kernels  # type: ignore[attr-defined]  # lazy: the C extension, when built
        except ImportError:
            _kernels = None
        _loaded.append(_kernels)
    return _loaded[0]


def choice() -> str:
    """``NDRQL_KERNELS`` (lower case), ``auto`` when unset; :class:`NdrqlError` for another value."""
    value = os.environ.get(KERNELS_ENV, "auto").strip().lower() or "auto"
    if value not in CHOICES:
        raise NdrqlError(f"{KERNELS_ENV}={value!r} is not one of {', '.join(CHOICES)}")
    return value


def c_kernels() -> ModuleType | None:
    """The extension when the C kernels are to run, None for numba (see :data:`KERNELS_ENV`)."""
    want = choice()
    if want == "numba":
        return None
    ext = extension()
    if ext is None and want == "c":
        raise NdrqlError(f"{KERNELS_ENV}=c, but the C extension ndrql.maps._kernels is not built (no C compiler "
                         f"at install time?); reinstall with a compiler, or unset {KERNELS_ENV} to use numba")
    return ext


def backend() -> str:
    """``"c"`` or ``"numba"``: which kernels run now."""
    return "c" if c_kernels() is not None else "numba"
