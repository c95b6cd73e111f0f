"""The exact source and NDR-QL's priors on it, compiled (issue 53's cheaper priors), give the bits of the numpy path
they replaced: the drawing, the goal distance, Eq. 6's tie-break and blur, and the whole ``build_priors``, on maps of
every shipped family (50-256 cells) and of random obstacles (12-256 cells)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from ndrql.dataset.render import PX_PER_CELL
from ndrql.maps import native
from ndrql.maps.grid import bfs_distances
from ndrql.pipeline import sources
from ndrql.planning import priors
from ndrql.planning.config import PriorConfig
from ndrql.planning.methods import build_priors
from ndrql.planning.priors import ThresholdWarning
from ndrql.synth.families import generate_map, shipped_families
from ndrql.synth.labels import GUIDE_PX, REGION_PX, near_optimal_path

pytestmark = pytest.mark.skipif(getattr(native.extension(), "route_cells", None) is None,
                                reason="the C extension ndrql.maps._kernels (with route_cells) is not built")


def _window_any(img, before, after, axis):
    a = np.asarray(img, dtype=bool)
    n = a.shape[axis]
    pad = [(0, 0), (0, 0)]
    pad[axis] = (before, 0)
    f = np.pad(a, pad)
    width, span = before + after + 1, 1
    cut = (lambda lo, hi: (slice(lo, hi), slice(None))) if axis == 0 else (lambda lo, hi: (slice(None), slice(lo, hi)))
    while span < width:
        step = min(span, width - span)
        f[cut(0, -step)] |= f[cut(step, None)]
        span += step
    return f[cut(0, n)]


def _cell_means(img, px):
    a = np.asarray(img, dtype=np.uint8)
    cols = sum(a[:, k::px] for k in range(px))
    return sum(cols[k::px].astype(np.uint16) for k in range(px)) / float(px * px)


def old_drawn_priors(blocked, start, goal):
    """``sources.drawn_priors`` as it was before its C kernels (numpy only): region, guideline, distance."""
    blocked = np.asarray(blocked, dtype=bool)
    px = PX_PER_CELL
    waypoints = near_optimal_path(blocked, start, goal).astype(np.float64) * px + (px - 1) / 2
    h, w = blocked.shape[0] * px, blocked.shape[1] * px
    pts = [waypoints[:1]]
    for a, b in zip(waypoints[:-1], waypoints[1:]):
        n = int(np.ceil(np.hypot(*(b - a)) / 0.25)) + 1
        pts.append(a + (b - a) * np.linspace(0.0, 1.0, n)[:, None])
    p = np.concatenate(pts)
    guide = np.zeros((h, w), dtype=bool)
    top = np.floor(p - (GUIDE_PX - 1) / 2).astype(np.int64)
    for dr in range(GUIDE_PX):
        for dc in range(GUIDE_PX):
            r, c = np.clip(top[:, 0] + dr, 0, h - 1), np.clip(top[:, 1] + dc, 0, w - 1)
            guide[r, c] = True
    before, after = REGION_PX // 2, REGION_PX - 1 - REGION_PX // 2
    region = _window_any(_window_any(guide, before, after, 0), before, after, 1)
    d = bfs_distances(blocked, goal).astype(np.float64)
    if (d < 0).any():
        rows, cols = np.indices(d.shape)
        far = (d.max() if (d >= 0).any() else 0.0) + np.abs(rows - goal[0]) + np.abs(cols - goal[1])
        d = np.where(d < 0, far, d)
    return _cell_means(region, px), _cell_means(guide, px), d


def _problems(count: int, seed: int):
    """Planning grids of every shipped family and of random obstacles, with a start and goal that connect."""
    gen = np.random.default_rng(seed)
    fams = shipped_families()
    made = 0
    while made < count:
        n = int(gen.choice([12, 23, 50, 64, 100, 128, 256])) if made % 4 == 0 else int(gen.choice([50, 64, 100, 256]))
        blocked = gen.random((n, n)) < 0.25 if made % 4 == 0 else generate_map(fams[made % len(fams)], gen, n, n)
        free = np.flatnonzero(~blocked.ravel())
        goal = divmod(int(gen.choice(free)), n)
        reach = np.flatnonzero(bfs_distances(blocked, goal).ravel() > 0)
        if reach.size:
            made += 1
            yield blocked, divmod(int(gen.choice(reach)), n), goal


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def test_exact_source_draws_the_old_bits(monkeypatch):
    """60 problems: region, guideline and goal distance of the compiled exact source are the old numpy ones."""
    monkeypatch.setenv(native.KERNELS_ENV, "c")
    for i, (blocked, start, goal) in enumerate(_problems(60, 531)):
        got = sources.drawn_priors("exact", blocked, start, goal, None)
        region, guide, dist = old_drawn_priors(blocked, start, goal)
        assert _same(got.region, region) and _same(got.guideline, guide) and _same(got.distance, dist), i


CONFIGS = (PriorConfig(),
           PriorConfig(region_dilation=1, guideline_ties=0.3, region_distance=1, thd_tail=1, thd_start=0.983,
                       thd_step=0.0919),
           PriorConfig(guideline_ties=0.95, omega_qi=0.8, region_distance=1))


def test_ndr_ql_priors_on_the_exact_source_are_the_numpy_bits(monkeypatch):
    """``build_priors`` of NDR-QL with the compiled blur and tie-break against numpy's loops (the fallback)."""
    monkeypatch.setenv(native.KERNELS_ENV, "c")
    for i, (blocked, start, goal) in enumerate(_problems(36, 532)):
        pr = sources.drawn_priors("exact", blocked, start, goal, None)
        cfg = CONFIGS[i % len(CONFIGS)]
        args = ("NDR-QL", blocked, start, goal, pr.region, pr.guideline, cfg, pr.distance)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ThresholdWarning)
            got = build_priors(*args)
            with monkeypatch.context() as m:
                m.setattr(priors, "c_kernels", lambda: None)
                ref = build_priors(*args)
        assert got.threshold == ref.threshold and _same(got.q0, ref.q0) and _same(got.r_c, ref.r_c), i


def test_blur_and_tie_break_are_numpys_on_any_values(monkeypatch):
    """Random fields (1-70 cells a side, sigma 0.1-5, ties with and without the route's nearness)."""
    monkeypatch.setenv(native.KERNELS_ENV, "c")
    gen = np.random.default_rng(533)
    for case in range(300):
        h, w = (int(x) for x in gen.integers(1, 71, size=2))
        values = gen.random((h, w)) * (gen.random((h, w)) < gen.random())
        sigma = float(gen.choice([0.5, 1.5, float(gen.uniform(0.1, 5.0))]))
        dist = np.round(gen.random((h, w)) * 3 * (h + w), int(gen.integers(0, 3)))
        goal = (int(gen.integers(0, h)), int(gen.integers(0, w)))
        near, weight = (values, float(gen.uniform(0.01, 0.95))) if case % 2 else (None, 0.0)
        got = priors.gaussian_blur(values, sigma), priors.snapped_distance(dist, goal, near, weight)
        with monkeypatch.context() as m:
            m.setattr(priors, "c_kernels", lambda: None)
            ref = priors.gaussian_blur(values, sigma), priors.snapped_distance(dist, goal, near, weight)
        assert _same(got[0], ref[0]) and _same(got[1], ref[1]), case


def test_priors_dispatch_to_the_kernels_when_built(monkeypatch):
    """With the extension the blur and the tie-break run its kernels; without it, numpy (the same answers)."""
    asked: list[str] = []

    class Spy:
        def __getattr__(self, name):
            asked.append(name)
            return getattr(native.extension(), name)

    monkeypatch.setattr(priors, "c_kernels", lambda: Spy())
    values = np.arange(30.0).reshape(5, 6)
    c = priors.gaussian_blur(values, 1.5), priors.snapped_distance(values, (2, 3), values / 29, 0.3)
    assert asked == ["gauss_blur", "snapped"]
    monkeypatch.setattr(priors, "c_kernels", lambda: None)
    ref = priors.gaussian_blur(values, 1.5), priors.snapped_distance(values, (2, 3), values / 29, 0.3)
    assert asked == ["gauss_blur", "snapped"] and _same(c[0], ref[0]) and _same(c[1], ref[1])
