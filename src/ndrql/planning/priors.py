"""The priors of the paper (Eqs. 2-7, docs/method.md), on the planning grid.

Two kinds, freely composed by :mod:`ndrql.planning.methods`:

- continuous rewards ``r_c`` (an ``(H, W)`` array, the reward of a plain move into a cell):
  D-CRF (Eq. 2), NDR-CRF (Eq. 3) and their mix (Eq. 4);
- Q-table initialisations (a ``(H * W, 4)`` array): D-QI (Eq. 5) and NDR-QI (Eq. 6, or its mask
  term alone for Table 2's ablation) whose mask (Eq. 7) uses the adaptive threshold of
  :func:`adaptive_threshold`; Eq. 6's distance term is the straight line (the paper) or, given, a
  predicted distance to the goal through free space, and with ``cfg.region_distance`` the moves to the
  goal through the thresholded region itself (:func:`region_distance`).

Coordinates: the paper's ``x`` is the row and ``y`` the column (the dataset's convention), so
``G_x`` is :attr:`PriorConfig.g_row`. Region and guideline arrays must already be at the planning
grid's resolution (see :func:`ndrql.planning.methods.downscale_priors`).
"""

from __future__ import annotations

import dataclasses
import functools
import warnings

import numpy as np

from ndrql.maps.fields import bottleneck4
from ndrql.maps.grid import bfs_distances
from ndrql.maps.native import c_kernels
from ndrql.maps.sizing import connected4  # the compiled A*: no scipy import (~0.15 s)
from ndrql.planning import rules
from ndrql.planning.config import PriorConfig


class ThresholdWarning(UserWarning):
    """NDR-QI found no threshold whose region connects start and goal; its mask is 0 everywhere."""


def _check_field(name: str, values: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    arr = np.asarray(values, dtype=np.float64)
    if arr.shape != tuple(shape):
        raise ValueError(
            f"{name} has shape {arr.shape} but the planning grid is {tuple(shape)}; "
            "downscale it first (ndrql.planning.methods.downscale_priors)"
        )
    return arr


def d_crf(shape: tuple[int, int], goal: tuple[int, int], cfg: PriorConfig = PriorConfig()) -> np.ndarray:
    """Eq. 2, D-CRF: ``r0 + r_max * exp(-|x - x_d| / G_x - |y - y_d| / G_y)`` per cell (x = row)."""
    rows = np.arange(shape[0], dtype=np.float64)[:, None]
    cols = np.arange(shape[1], dtype=np.float64)[None, :]
    return cfg.r0 + cfg.r_max * np.exp(-np.abs(rows - goal[0]) / cfg.g_row - np.abs(cols - goal[1]) / cfg.g_col)


def ndr_crf(guideline: np.ndarray, cfg: PriorConfig = PriorConfig()) -> np.ndarray:
    """Eq. 3, NDR-CRF: ``NDR_g(cell) * r_max`` (``guideline`` = probabilities on the planning grid)."""
    return np.asarray(guideline, dtype=np.float64) * cfg.r_max


def mixed_crf(guideline: np.ndarray, goal: tuple[int, int], cfg: PriorConfig = PriorConfig()) -> np.ndarray:
    """Eq. 4: ``omega * NDR-CRF + (1 - omega) * (D-CRF - r0) + r0``.

    The paper omits ``r0`` "for simplicity"; it is added back once as a base (0 by default).
    """
    g = np.asarray(guideline, dtype=np.float64)
    dist = d_crf(g.shape, goal, cfg) - cfg.r0
    return cfg.r0 + cfg.omega_crf * ndr_crf(g, cfg) + (1.0 - cfg.omega_crf) * dist


def _at_next(per_cell: np.ndarray, nxt: np.ndarray) -> np.ndarray:
    """A per-cell field read at ``s'`` for every ``(s, a)`` (``nxt`` = :func:`rules.next_table`), ``(H * W, 4)``.

    Every term of Eqs. 5-6 depends on ``s'`` alone, so it is computed once per cell and gathered once: the same
    floating-point operations on the same values as computing it per ``(s, a)``, a quarter of the work."""
    return per_cell.ravel()[nxt]


def _straight(shape: tuple[int, int], goal: tuple[int, int]) -> np.ndarray:
    """The straight-line distance (cells) from every cell to ``goal``, ``(H, W)`` float64, read-only (the last few
    are kept: every seed's run on a grid builds its priors again, and ``hypot`` is most of Eq. 6's tie-break)."""
    return _straight_field(int(shape[0]), int(shape[1]), int(goal[0]), int(goal[1]))


@functools.lru_cache(maxsize=4)
def _straight_field(h: int, w: int, g0: int, g1: int) -> np.ndarray:
    rows = np.arange(h, dtype=np.int64)[:, None]
    cols = np.arange(w, dtype=np.int64)[None, :]
    out = np.hypot(rows - g0, cols - g1)
    out.setflags(write=False)
    return out


def d_qi(blocked: np.ndarray, goal: tuple[int, int], distance: np.ndarray | None = None) -> np.ndarray:
    """Eq. 5, D-QI: ``Q(s, a) = exp(-dist(s', goal))``, ``s'`` where ``a`` leads, Euclidean in cells.

    ``distance`` (cells, the grid's shape), beyond the paper: ``dist`` read from this field instead of
    the straight line, e.g. the exact BFS distance to the goal (a reference without learning)."""
    blocked = np.asarray(blocked, dtype=bool)
    dist = _straight(blocked.shape, goal) if distance is None else _check_distance(distance, blocked.shape)
    return _at_next(np.exp(-dist), rules.next_table(blocked))


def exact_distance(blocked: np.ndarray, goal: tuple[int, int]) -> np.ndarray:
    """The exact goal distance per cell (beyond the paper): 4-connected moves to ``goal`` through free cells, the
    largest such distance plus one where a cell cannot reach it (blocked cells included). ``(H, W)`` float64;
    what :func:`d_qi` takes for IQL-BFS and the oracle's distance in the reports."""
    d = bfs_distances(np.asarray(blocked, dtype=bool), goal).astype(np.float64)
    return np.where(d >= 0, d, d.max() + 1.0)


def region_connects(
    region: np.ndarray, blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int], thd: float
) -> bool:
    """Whether the free cells with ``region > thd`` 4-connect ``start`` and ``goal``."""
    inside = (np.asarray(region) > thd) & ~np.asarray(blocked, dtype=bool)
    if not (inside[tuple(start)] and inside[tuple(goal)]):
        return False
    return connected4(~inside, tuple(start), tuple(goal))


#: The step of the paper's schedule (Sec. 3.3), by which ``thd_tail`` goes on below a coarser schedule's end.
PAPER_STEP = 0.01


def threshold_schedule(cfg: PriorConfig = PriorConfig()) -> list[float]:
    """The thresholds Eq. 7's search tries, highest first: ``thd_start`` down by ``thd_step`` while at least 0
    (rounded to 1e-9; the paper's 0.99, 0.98, ..., 0); with ``thd_tail`` 1 a schedule that ends above 0 goes on
    at the multiples of 0.01 below its end, down to 0."""
    return list(_schedule(float(cfg.thd_start), float(cfg.thd_step), int(cfg.thd_tail)))


@functools.lru_cache(maxsize=32)
def _schedule(thd_start: float, thd_step: float, thd_tail: int) -> tuple[float, ...]:
    """:func:`threshold_schedule` of these constants, computed once (two Eq. 7 searches a plan ask for it)."""
    n = int(np.floor(thd_start / thd_step + 1e-9))
    sched = [t + 0.0 for t in (round(thd_start - i * thd_step, 9) for i in range(n + 1)) if t >= 0]  # no -0.0
    if thd_tail and sched[-1] > 0:
        below = int(np.ceil(sched[-1] / PAPER_STEP - 1e-9)) - 1  # the largest multiple of 0.01 below the end
        sched += [round(k * PAPER_STEP, 9) for k in range(below, -1, -1)]
    return tuple(sched)


def schedule_text(cfg: PriorConfig = PriorConfig()) -> str:
    """The schedule of :func:`threshold_schedule` in words: ``[0, 0.99]`` for the paper's, with the step when it
    is not 0.01 (``[0.0639, 0.983] by 0.0919``)."""
    if cfg.thd_tail:
        coarse = threshold_schedule(dataclasses.replace(cfg, thd_tail=0))
        if coarse[-1] > 0:
            return f"{schedule_text(dataclasses.replace(cfg, thd_tail=0))}, then by 0.01 to 0"
    sched = threshold_schedule(cfg)
    step = "" if abs(cfg.thd_step - 0.01) < 1e-12 else f" by {cfg.thd_step:.3g}"
    return f"[{sched[-1]:.3g}, {sched[0]:.3g}]{step}"


def adaptive_threshold(
    region: np.ndarray,
    blocked: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    cfg: PriorConfig = PriorConfig(),
) -> float | None:
    """The threshold ``thd`` of Eq. 7 (:func:`region_mask`): from ``thd_start`` down by ``thd_step`` until the
    region connects start and goal (Sec. 3.3).

    Returns the highest such threshold (rounded to 1e-9, so 0.99, 0.98, ... exactly), or ``None``
    when not even the schedule's lowest connects start and goal. Found in one pass: the free cells with
    ``region > t`` join start and goal exactly when ``t`` lies below the widest path's smallest region value
    ``B`` (:func:`ndrql.maps.fields.bottleneck4`), so the answer is the first entry of
    :func:`threshold_schedule` below ``B``: the walk down's answer, with one search of the grid instead of one
    :func:`region_connects` per threshold tried.
    """
    blocked = np.asarray(blocked, dtype=bool)
    region = _check_field("region", region, blocked.shape)
    widest = bottleneck4(region, blocked, start, goal)
    return next((t for t in threshold_schedule(cfg) if t < widest), None)


def region_mask(region: np.ndarray, thd: float | None, cfg: PriorConfig = PriorConfig()) -> np.ndarray:
    """Eq. 7: 0 where ``N_r > thd``, ``mask_low`` (-10) elsewhere; all 0 when ``thd`` is ``None``."""
    region = np.asarray(region, dtype=np.float64)
    if thd is None:
        return np.zeros_like(region)
    return np.where(region > thd, 0.0, cfg.mask_low)


def ndr_qi_mask_term(blocked: np.ndarray, region: np.ndarray, thd: float | None,
                     cfg: PriorConfig = PriorConfig()) -> np.ndarray:
    """The mask term of Eq. 6 alone: ``Q(s, a) = omega * MASK(N_r(s'))`` (Table 2's ablation row N-Q).

    ``thd`` is the threshold of Eq. 7 (``None``: MASK is 0 everywhere). :func:`ndr_qi` adds the distance term.
    """
    blocked = np.asarray(blocked, dtype=bool)
    mask = region_mask(_check_field("region", region, blocked.shape), thd, cfg)
    return _at_next(cfg.omega_qi * mask, rules.next_table(blocked))


def ndr_qi(
    blocked: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    region: np.ndarray,
    cfg: PriorConfig = PriorConfig(),
    thd: float | None = ...,  # type: ignore[assignment]
    mask_only: bool = False,
    distance: np.ndarray | None = None,
    guideline: np.ndarray | None = None,
) -> tuple[np.ndarray, float | None]:
    """Eq. 6, NDR-QI: ``Q(s, a) = omega * MASK(N_r(s')) + (1 - omega) * exp(-dist(s', goal))``.

    ``thd`` defaults to :func:`adaptive_threshold` (of the region widened by ``cfg.region_dilation``
    cells, :func:`widen_region`); when none connects, MASK is 0 everywhere and a
    :class:`ThresholdWarning` is emitted. ``mask_only``: the mask term alone
    (:func:`ndr_qi_mask_term`). ``distance``: the model's predicted distance to the goal through free
    space per cell, in cells (beyond the paper), taken as ``dist(s', goal)`` after
    :func:`snapped_distance`; default the straight line, as in the paper. ``guideline`` (with
    ``distance`` and ``cfg.guideline_ties > 0``): equally distant moves are told apart by how near
    they lie to the predicted route (:func:`route_nearness`) rather than by the straight line alone.
    ``cfg.region_distance`` (beyond the paper): ``dist(s', goal)`` counts the moves through the region
    above ``thd`` wherever it reaches the goal (:func:`region_distance`), so the distance term and the mask
    agree on the route. Returns ``(q0, thd)``.
    """
    blocked = np.asarray(blocked, dtype=bool)
    region = widen_region(_check_field("region", region, blocked.shape), cfg.region_dilation)
    if thd is ...:
        thd = adaptive_threshold(region, blocked, start, goal, cfg)
        if thd is None:
            warnings.warn(
                f"NDR-QI: no threshold in {schedule_text(cfg)} makes the region connect start and goal; "
                "the region mask is 0 everywhere",
                ThresholdWarning,
                stacklevel=2,
            )
    nxt = rules.next_table(blocked)
    masked = cfg.omega_qi * region_mask(region, thd, cfg)  # per cell, as every term below (_at_next)
    if mask_only:
        return _at_next(masked, nxt), thd
    if cfg.region_distance and thd is not None:
        distance = region_distance(blocked, region, thd, goal, distance)
    if distance is None:
        dist = _straight(blocked.shape, goal)
    else:
        near = None
        if guideline is not None and cfg.guideline_ties > 0:
            near = route_nearness(_check_field("guideline", guideline, blocked.shape))
        dist = snapped_distance(_check_distance(distance, blocked.shape), goal, near, cfg.guideline_ties)
    return _at_next(masked + (1.0 - cfg.omega_qi) * np.exp(-dist), nxt), thd


def region_distance(blocked: np.ndarray, region: np.ndarray, thd: float, goal: tuple[int, int],
                    distance: np.ndarray | None = None) -> np.ndarray:
    """The distance through the region, for Eq. 6's ``dist(s, goal)`` (beyond the paper;
    :attr:`PriorConfig.region_distance`): per cell, the number of 4-connected moves to ``goal`` through free
    cells whose region value is above ``thd`` (the cells Eq. 7's mask leaves at 0), wherever those cells reach
    the goal; elsewhere ``distance`` (cells) or, without it, the straight line. ``(H, W)`` float64.

    A predicted distance field can promise a shorter way than the region holds (a gap the region's band
    crosses, a pocket where it dips); counted through the region, every cell's distance falls by one along
    some move that stays inside, so the distance term leads where the mask lets the agent go
    (studies/large_view/history.md#distance-through-the-region)."""
    blocked = np.asarray(blocked, dtype=bool)
    inside = bfs_distances(blocked | ~(_check_field("region", region, blocked.shape) > thd), goal)
    other = _straight(blocked.shape, goal) if distance is None else _check_distance(distance, blocked.shape)
    return np.where(inside >= 0, inside.astype(np.float64), other)


#: Weight of the straight line that breaks ties between equally distant cells in :func:`snapped_distance`.
TIE_BREAK = 0.01


#: Gaussian blur (cells) of the guideline in :func:`route_nearness`: a few cells either side of the route
#: lean towards it, so that a move beside the route is still told which way the route lies.
GUIDELINE_BLUR = 1.5


def widen_region(region: np.ndarray, cells: int) -> np.ndarray:
    """The region widened by ``cells`` (beyond the paper, :attr:`PriorConfig.region_dilation`): each cell
    takes the highest value within ``cells`` 4-connected moves (a grey dilation by a diamond).

    Eq. 7's mask then leaves the predicted corridor's thresholded edge a little room, so that a move the
    distance term prefers is not cut off by a cell the threshold just missed. ``cells = 0``: unchanged.
    ``scipy.ndimage.grey_dilation`` by that diamond (its ``reflect`` border only repeats values the diamond
    already holds), for finite regions bit for bit, without importing scipy (~0.15 s a plan).
    """
    region = np.asarray(region, dtype=np.float64)
    if not cells:
        return region
    out = region
    for _ in range(int(cells)):  # the diamond of radius k is k crosses in turn; the grid's edge clips them alike
        prev, out = out, out.copy()
        np.maximum(out[1:], prev[:-1], out=out[1:])
        np.maximum(out[:-1], prev[1:], out=out[:-1])
        np.maximum(out[:, 1:], prev[:, :-1], out=out[:, 1:])
        np.maximum(out[:, :-1], prev[:, 1:], out=out[:, :-1])
    return out


def gaussian_blur(values: np.ndarray, sigma: float) -> np.ndarray:
    """``scipy.ndimage.gaussian_filter(values, sigma)`` of a 2-D float64 array, bit for bit, without scipy.

    The same kernel (radius ``int(4 * sigma + 0.5)``, normalised by its sum), the same ``reflect``
    border (``d c b a | a b c d | d c b a``), rows then columns, and the same order of sums as scipy's
    symmetric correlation (centre first, then each pair of cells from the outermost in), so that the
    floating-point result is identical; importing ``scipy.ndimage`` would cost a plan ~0.15 s. The C extension
    runs the same loop when it is built (:mod:`ndrql.maps.native`), else numpy.
    """
    radius, weights = _gauss_weights(float(sigma))
    out = np.asarray(values, dtype=np.float64)
    kernel = getattr(c_kernels(), "gauss_blur", None)  # the same loop compiled, when built
    if kernel is not None and out.ndim == 2 and out.size:
        h, w = out.shape
        flat = kernel(np.ascontiguousarray(out), h, w, np.ascontiguousarray(weights), radius)
        return np.frombuffer(flat, dtype=np.float64).reshape(h, w)
    for axis in (0, 1):
        line = np.moveaxis(out, axis, 0)
        n = line.shape[0]
        idx = np.mod(np.arange(-radius, n + radius), 2 * n)  # reflect, repeated for lines shorter than the kernel
        padded = line[np.where(idx >= n, 2 * n - 1 - idx, idx)]
        acc = padded[radius:radius + n] * weights[radius]
        for j in range(radius, 0, -1):
            acc = acc + (padded[radius - j:radius - j + n] + padded[radius + j:radius + j + n]) * weights[radius - j]
        out = np.moveaxis(acc, 0, axis)
    return out


@functools.lru_cache(maxsize=8)
def _gauss_weights(sigma: float) -> tuple[int, np.ndarray]:
    """The radius and normalised weights of :func:`gaussian_blur`'s kernel (read-only), computed once per sigma."""
    radius = int(4.0 * sigma + 0.5)
    x = np.arange(-radius, radius + 1)
    weights = np.exp(-0.5 / (sigma * sigma) * x**2)
    weights = weights / weights.sum()
    weights.setflags(write=False)
    return radius, weights


def route_nearness(guideline: np.ndarray) -> np.ndarray:
    """How near each cell lies to the predicted route, in [0, 1]: the guideline (Eq. 3's probabilities on
    the planning grid) blurred by :data:`GUIDELINE_BLUR` cells and scaled to a maximum of 1 (all 0 when
    the guideline is empty)."""
    near = gaussian_blur(np.asarray(guideline, dtype=np.float64), GUIDELINE_BLUR)
    top = float(near.max())
    return near / top if top > 0 else np.zeros_like(near)


def snapped_distance(distance: np.ndarray, goal: tuple[int, int], nearness: np.ndarray | None = None,
                     weight: float = 0.0) -> np.ndarray:
    """A predicted distance to the goal (cells) as Eq. 6 takes it: snapped to the values a 4-connected
    distance can take, and with ties broken by the straight line (and, given ``nearness`` and a
    ``weight`` in (0, 0.95], by the route: ``+ weight * (1 - nearness)``).

    The moves from a cell to the goal are its Manhattan distance plus an even detour (a grid is
    bipartite), so the predicted detour ``distance - manhattan`` is rounded to the nearest even number
    of moves (at least 0): the model's small, noisy detours in open space become 0 and leave the order
    of neighbours to the geometry. Neighbours that are then equally far (in open space two moves
    usually are) are told apart by :data:`TIE_BREAK` times their straight-line distance, which prefers
    the move that heads more directly for the goal, as Eq. 5 does. An exact distance (the oracle's)
    keeps its order.

    On a 4-connected grid many routes are equally short, and the straight line picks one of them
    without looking at the region: where it leads out of the corridor Eq. 7's mask allows, the greedy
    policy of Eq. 6 is cornered between the two terms (a move the distance wants and the mask forbids).
    ``nearness`` (:func:`route_nearness`) breaks the ties towards the predicted route instead; two
    neighbours' snapped values differ by at least one move, and the tie terms by less, so the order of
    unequal distances never changes.
    """
    d = np.asarray(distance, dtype=np.float64)
    kernel = getattr(c_kernels(), "snapped", None)  # the same operations compiled, when built
    if kernel is not None and d.ndim == 2 and d.size:
        near = np.ascontiguousarray(nearness, np.float64) if nearness is not None and weight > 0 else None
        if near is None or near.shape == d.shape:
            h, w = d.shape
            flat = kernel(np.ascontiguousarray(d), near, _straight(d.shape, goal), h, w, int(goal[0]), int(goal[1]),
                              TIE_BREAK, float(weight))
            return np.frombuffer(flat, dtype=np.float64).reshape(h, w)
    rows = np.arange(d.shape[0], dtype=np.int64)[:, None]
    cols = np.arange(d.shape[1], dtype=np.int64)[None, :]
    manhattan = np.abs(rows - goal[0]) + np.abs(cols - goal[1])
    ties = TIE_BREAK * _straight(d.shape, goal)
    if nearness is not None and weight > 0:
        ties = ties + weight * (1.0 - np.asarray(nearness, dtype=np.float64))
    return manhattan + snap_detour(d - manhattan) + ties


def snap_detour(detour: np.ndarray) -> np.ndarray:
    """A predicted detour over the Manhattan distance (cells) rounded to the nearest even number of moves,
    at least 0 (:func:`snapped_distance`)."""
    return 2.0 * np.round(np.maximum(np.asarray(detour, dtype=np.float64), 0.0) / 2.0)


def _check_distance(values: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """A goal-distance field (cells, finite, >= 0 after clipping) of the grid's shape, as float64."""
    d = _check_field("distance", values, shape)
    if not np.all(np.isfinite(d)):
        raise ValueError("distance must be finite everywhere")
    return np.maximum(d, 0.0)
