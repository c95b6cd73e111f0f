"""The C Q-learning kernel (``ndrql.maps._kernels``) makes numba's run bit for bit, on many random problems.

numba's :func:`ndrql.planning.kernel.train` is the reference; :func:`ndrql.planning.compiled.train` with
``NDRQL_KERNELS=c`` runs the C port. Every output is compared exactly: the Q-table, the episode count,
the per-episode steps, returns, successes and greedy lengths (whole record arrays, grown capacity
included), convergence episode and steps, and the greedy path. The problems cover random grids,
starts and goals, every method's priors (and raw random priors with many ties), seeds, epsilon from 0 to
1, learning rates, discounts, rewards, step and episode caps and windows.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from ndrql.errors import NdrqlError
from ndrql.maps import native
from ndrql.planning import compiled, kernel, rng, rules
from ndrql.planning.methods import METHODS, build_priors
from ndrql.planning.priors import ThresholdWarning

pytestmark = pytest.mark.skipif(native.extension() is None, reason="the C extension ndrql.maps._kernels is not built "
                                "(pip install -e . with a C compiler, or python setup.py build_ext --inplace)")


@pytest.fixture
def use_c(monkeypatch):
    monkeypatch.setenv(native.KERNELS_ENV, "c")


def _random_grid(gen: np.random.Generator) -> tuple[np.ndarray, int, int]:
    """A random grid (2-14 x 2-14, obstacle density 0-0.45) and two distinct free cells (flat indices)."""
    while True:
        h, w = (int(x) for x in gen.integers(2, 15, size=2))
        blocked = gen.random((h, w)) < gen.uniform(0.0, 0.45)
        free = np.flatnonzero(~blocked.ravel())
        if free.size >= 2:
            s, g = gen.choice(free, size=2, replace=False)
            return blocked, int(s), int(g)


def _priors(gen: np.random.Generator, blocked: np.ndarray, s: int, g: int) -> tuple[np.ndarray, np.ndarray]:
    """``(r_c flat, q0)``: a method's own priors on random predictions, or raw random values with ties."""
    h, w = blocked.shape
    kind = gen.integers(0, 3)
    if kind == 0:  # a method of the paper, on random NDR predictions
        name = str(gen.choice(sorted(METHODS)))
        region = gen.random((h, w))
        guideline = gen.random((h, w))
        distance = gen.random((h, w)) * (h + w) if gen.random() < 0.5 else None
        if distance is None and METHODS[name].model_distance:  # IQL-NDR needs one: the region's, scaled
            distance = region * (h + w)
        with warnings.catch_warnings():  # start and goal may be apart: NDR-QI then says its mask is empty
            warnings.simplefilter("ignore", ThresholdWarning)
            pr = build_priors(name, blocked, divmod(s, w), divmod(g, w), region, guideline, distance=distance)
        return np.ascontiguousarray(pr.r_c, dtype=np.float64).ravel(), np.array(pr.q0, dtype=np.float64, order="C")
    if kind == 1:  # few distinct values: many tied maxima, so the random tie-break is exercised
        return gen.integers(-2, 3, size=h * w).astype(np.float64), gen.integers(-1, 2, size=(h * w, 4)).astype(np.float64)
    return gen.normal(size=h * w), gen.normal(size=(h * w, 4)) * gen.uniform(0, 5)


def _problem(gen: np.random.Generator) -> tuple:
    blocked, s, g = _random_grid(gen)
    r_c, q0 = _priors(gen, blocked, s, g)
    cells = blocked.size
    eps = float(gen.choice([0.0, 1.0, gen.uniform(0, 1), 0.2]))
    args = (rules.next_table(blocked), s, g, r_c, q0, int(gen.integers(0, 2**63 - 1)), float(gen.uniform(0.01, 1.0)),
            float(gen.uniform(0.5, 1.0)), rng.eps_threshold(eps), int(gen.choice([cells, 4 * cells, 3, 40 * cells])),
            int(gen.choice([1, 5, 300, 2000])), int(gen.integers(1, 25)), float(gen.uniform(-20, 0)),
            float(gen.uniform(1, 80)), float(gen.uniform(-10, 0)))
    return args


def _same(a: tuple, b: tuple) -> None:
    n, path_len = a[0], a[7]
    assert type(a[0]) is type(b[0]) is int
    for i, (x, y) in enumerate(zip(a, b)):
        if i == 8:  # the path: valid up to path_len (numba leaves the rest of the buffer uninitialised)
            assert x.dtype == y.dtype and x.shape == y.shape
            assert np.array_equal(x[: path_len + 1], y[: path_len + 1])
        elif isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape, i
            assert x.tobytes() == y.tobytes(), (i, n)  # bit for bit (float returns included)
        else:
            assert x == y, i


def _both(args: tuple) -> tuple[tuple, np.ndarray, tuple, np.ndarray]:
    q_nb, q_c = args[4].copy(), args[4].copy()
    out_nb = kernel.train(*args[:4], q_nb, *args[5:])
    out_c = compiled.train(*args[:4], q_c, *args[5:])
    return out_nb, q_nb, out_c, q_c


@pytest.mark.parametrize("block", range(4))
def test_c_train_equals_numba_on_random_problems(use_c, block):
    """150 random problems per block (600 in all)."""
    gen = np.random.default_rng(1000 + block)
    converged = found = 0
    for case in range(150):
        args = _problem(gen)
        out_nb, q_nb, out_c, q_c = _both(args)
        assert q_nb.tobytes() == q_c.tobytes(), (block, case)
        _same(out_nb, out_c)
        converged += out_nb[5] >= 0
        found += out_nb[7] >= 0
    assert 20 <= converged < 150 and found > converged  # converged runs, runs that never did, paths found on the way


def test_c_train_equals_numba_on_a_long_run_past_the_first_records(use_c):
    """A run of thousands of episodes (the records grow twice) on a larger maze."""
    gen = np.random.default_rng(7)
    blocked = gen.random((30, 30)) < 0.25
    blocked[0, 0] = blocked[29, 29] = False
    pr = build_priors("QL", blocked, (0, 0), (29, 29))
    args = (rules.next_table(blocked), 0, 899, pr.r_c.ravel(), pr.q0, 5, 0.1, 0.95, rng.eps_threshold(0.3), 3600,
            2500, 2400, -10.0, 40.0, -5.0)
    out_nb, q_nb, out_c, q_c = _both(args)
    assert out_nb[0] > 1024 or out_nb[5] < 0
    assert q_nb.tobytes() == q_c.tobytes()
    _same(out_nb, out_c)


def _same_or_both_nan(a: np.ndarray, b: np.ndarray) -> None:
    """Bit for bit, except that a NaN may come out with another sign or payload: IEEE 754 leaves which input
    NaN an operation passes on to the compiler's operand order (``inf - inf`` gives x86's negative default
    NaN, which an addition may pass on or not). Real runs never meet a NaN: every prior and knob is finite."""
    nan = np.isnan(a)
    assert np.array_equal(nan, np.isnan(b))
    assert a[~nan].tobytes() == b[~nan].tobytes()


def test_c_train_equals_numba_on_hostile_values(use_c):
    """NaN and infinite priors, a zero episode cap, zero steps: the same comparisons, the same run (every
    record, the path, the convergence; the Q-table and returns up to the sign of a NaN)."""
    gen = np.random.default_rng(3)
    for case in range(40):
        args = list(_problem(gen))
        q0 = args[4]
        q0[gen.random(q0.shape) < 0.2] = float(gen.choice([np.nan, np.inf, -np.inf]))
        args[3] = np.where(gen.random(args[3].shape) < 0.1, np.nan, args[3])
        if case % 10 == 0:
            args[10] = 0
        if case % 10 == 1:
            args[9] = 0
        out_nb, q_nb, out_c, q_c = _both(tuple(args))
        _same_or_both_nan(q_nb, q_c)
        _same_or_both_nan(out_nb[2], out_c[2])  # returns
        _same((*out_nb[:2], None, *out_nb[3:]), (*out_c[:2], None, *out_c[3:]))


def test_c_generator_equals_numba(use_c):
    for seed in (0, 1, 7, 2**63 - 1, 123456789, *np.random.default_rng(0).integers(0, 2**63 - 1, size=20).tolist()):
        assert compiled.draws(seed, 200).tobytes() == kernel._draws(seed, 200).tobytes()


def test_the_choice_follows_the_environment(monkeypatch):
    monkeypatch.setenv(native.KERNELS_ENV, "numba")
    assert compiled.backend() == "numba" and native.c_kernels() is None
    monkeypatch.setenv(native.KERNELS_ENV, "C")
    assert compiled.backend() == "c" and compiled.compile_notice() is None
    monkeypatch.delenv(native.KERNELS_ENV)
    assert compiled.backend() == "c"  # auto: the extension when it is built
    monkeypatch.setenv(native.KERNELS_ENV, "fortran")
    with pytest.raises(NdrqlError, match="NDRQL_KERNELS"):
        native.backend()


def test_c_train_checks_its_arrays(use_c):
    blocked = np.zeros((2, 2), dtype=bool)
    args = (rules.next_table(blocked), 0, 3, np.zeros(4), np.zeros((4, 4)), 0, 0.1, 0.9, 0, 8, 1, 1, -1.0, 1.0, -1.0)
    with pytest.raises(TypeError, match="q must be"):
        compiled.train(*args[:4], np.zeros((4, 4), dtype=np.float32), *args[5:])
    with pytest.raises(ValueError, match="r_c"):
        compiled.train(*args[:3], np.zeros(2), *args[4:])
    with pytest.raises(IndexError):
        compiled.train(args[0], 0, 9, *args[3:])
