"""Build of the optional C extension ``ndrql.maps._kernels`` (everything else is in pyproject.toml).

The extension holds the planners' kernels compiled ahead of time, so the first ``ndrql plan`` after an
install compiles nothing. It is optional: without a C compiler the install still succeeds and ndrql
runs the same kernels through numba (compiled on first use), with bit-identical results.
``-ffp-contract=off`` (no fused multiply-add) and no ``-ffast-math`` keep every floating-point
operation exactly as numba performs it.
"""

import sys

from setuptools import Extension, setup

FLAGS = [] if sys.platform == "win32" else ["-O2", "-ffp-contract=off", "-fno-fast-math"]

setup(
    ext_modules=[
        Extension("ndrql.maps._kernels", ["src/ndrql/maps/_kernels.c"], extra_compile_args=FLAGS, optional=True),
    ],
)
