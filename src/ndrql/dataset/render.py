"""What the model sees and learns, for a planning grid of ``n`` cells: the two input modes.

- ``map`` (the paper's input): the map itself resized to ``4n + 1`` px (201 for the paper's 50x50
  grid), start and goal scaled with it; labels are the map's near-optimal path drawn at that scale
  (guideline 2 px, region its 30x30 dilation, as the dataset defines them).
- ``grid``: the planning grid the planner will solve (the conservative downscale, a cell blocked if
  any pixel is), rendered at 4 px per cell; labels are the grid's own shortest path drawn the same way
  (:func:`ndrql.synth.oracle.oracle_prediction`), i.e. the oracle's arrays.

In both modes the model sees about 4 px per planning cell whatever the grid, so the label widths
(2 and 30 px) keep the same meaning in cells. A sample that the mode cannot use (start and goal
disconnected or in one cell on the grid) renders to ``None``.

A map of another size meets a ``map``-mode model through :func:`to_model_input`: the longer side
resized to 201 px by whole pixels (:func:`ndrql.maps.area.whole_pixel_majority`: a cell blocked when
at least half of its pixels are obstacles; the rule the models were trained on, not the planning
grid's exact-area rule), the shorter side padded with obstacles to 201, start and goal scaled with it
(moved to the nearest free pixel if the resize blocked them); :func:`from_model_output` maps the
probabilities back (each map pixel samples the model pixel its centre falls in).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ndrql.errors import NdrqlError, NoPathError
from ndrql.maps.area import whole_pixel_majority
from ndrql.maps.belief import unknown_cells
from ndrql.maps import sizing  # sizing.safe_grid, read at each call: the one builder
from ndrql.maps.grid import MODEL_SIDE, area_downscale, bfs_distances, nearest_free_euclidean
from ndrql.maps.problem import MapProblem
from ndrql.maps.safe import grid_shape
from ndrql.synth.labels import dilate_region, draw_guideline
from ndrql.synth.oracle import oracle_prediction

Point = tuple[int, int]

#: Input modes of the model (saved in the model config as ``input_mode``).
INPUT_MODES = ("map", "grid")
#: Pixels per planning cell in the model's input.
PX_PER_CELL = 4
#: Planning cells per unit of the model's goal-distance output (:func:`manhattan_pixels`).
DISTANCE_UNIT = 16.0


@dataclass(frozen=True)
class Rendered(MapProblem):
    """One model input (the map, start and goal at the model's scale) and its labels, all (side, side)."""

    guideline: np.ndarray
    """bool, the path drawn 2 px wide."""
    region: np.ndarray
    """bool, the guideline's 30x30 dilation."""
    distance: np.ndarray | None = None
    """float32, each pixel's cell's distance to the goal cell in 4-connected moves (the planner's
    actions), -1 where blocked or unreachable (``grid`` mode; ``None`` in ``map`` mode)."""
    unknown: np.ndarray | None = None
    """bool, the pixels of the cells unknown to the planner (:func:`render_belief_grid`); ``None``: a known map."""


def input_side(mode: str, n: int) -> int:
    """Side of the model input for a planning grid of ``n`` cells: ``4n + 1`` (map) or ``4n`` (grid)."""
    if mode not in INPUT_MODES:
        raise NdrqlError(f"unknown input mode {mode!r}; valid: {', '.join(INPUT_MODES)}")
    return PX_PER_CELL * n + (1 if mode == "map" else 0)


def grid_input(blocked: np.ndarray, start_cell: Point, goal_cell: Point, n: int,
               px: int = PX_PER_CELL) -> tuple[np.ndarray, Point, Point]:
    """The planning grid as the model's input: ``px`` (default 4) px per cell, padded with obstacles to ``px n`` square."""
    side = px * n
    img = np.ones((side, side), bool)
    up = np.kron(np.asarray(blocked, np.uint8), np.ones((px, px), np.uint8)).astype(bool)
    img[:up.shape[0], :up.shape[1]] = up
    mid = px // 2
    return img, (start_cell[0] * px + mid, start_cell[1] * px + mid), (goal_cell[0] * px + mid, goal_cell[1] * px + mid)


def connected_grid(obstacles: np.ndarray, start: Point, goal: Point, n: int) -> tuple[np.ndarray, Point, Point] | None:
    """The safe grid of ``n`` cells with start and goal placed as ``ndrql plan`` places them
    (:func:`ndrql.maps.sizing.safe_grid`: a point whose cell is blocked moves to a nearby free cell it can
    see): ``(blocked, start_cell, goal_cell)``, or ``None`` when they fall in one cell or do not connect."""
    try:
        pg = sizing.safe_grid(obstacles, n, start, goal)
    except NoPathError:  # no free cell at all at this size
        return None
    blocked, s, g = pg.blocked, pg.start, pg.goal
    if s == g or blocked[s] or blocked[g] or bfs_distances(blocked, s)[g] < 0:
        return None
    return blocked, s, g


def _cell_blocks(blocked: np.ndarray, f: int) -> np.ndarray:
    """``blocked`` padded with blocked cells to multiples of ``f`` and viewed as ``(H, f, W, f)`` blocks."""
    h, w = blocked.shape
    H, W = -(-h // f), -(-w // f)
    pad = np.ones((H * f, W * f), bool)
    pad[:h, :w] = blocked
    return pad.reshape(H, f, W, f)


def merge_cells(blocked: np.ndarray, f: int) -> np.ndarray:
    """``f`` x ``f`` cells into one, free when any of them is free (padding counts as blocked)."""
    blocked = np.asarray(blocked, bool)
    return blocked if f == 1 else _cell_blocks(blocked, f).all(axis=(1, 3))


def merge_walls(blocked: np.ndarray, f: int, start: Point, goal: Point) -> np.ndarray:
    """``f`` x ``f`` cells into one, blocked when any of them is blocked, so walls one cell thick stay walls
    (padding counts as blocked; the merged cells of ``start`` and ``goal``, planning cells, stay free); when
    that closes every 4-connected route between them, :func:`merge_cells` (free when any cell is free)."""
    blocked = np.asarray(blocked, bool)
    if f == 1:
        return blocked
    walls = _cell_blocks(blocked, f).any(axis=(1, 3))
    s, g = (start[0] // f, start[1] // f), (goal[0] // f, goal[1] // f)
    walls[s] = walls[g] = False
    if s != g and bfs_distances(walls, s)[g] >= 0:
        return walls
    return merge_cells(blocked, f)


def merged_grid(blocked: np.ndarray, f: int, start: Point, goal: Point, keep_walls: bool) -> np.ndarray:
    """The grid a merging view shows: :func:`merge_walls` when ``keep_walls`` (the ``walls`` view), else
    :func:`merge_cells` (the ``coarse`` view)."""
    return merge_walls(blocked, f, start, goal) if keep_walls else merge_cells(blocked, f)


def render_grid(obstacles: np.ndarray, start: Point, goal: Point, n: int, view=None) -> Rendered | None:
    """``grid`` mode: conservative grid of ``n`` cells, 4 px per cell, oracle labels.

    ``view`` (a :class:`ndrql.dataset.views.GridView`; ``None`` or ``native`` is the above) draws the grid as
    that view shows it to the model: the merged grid of a ``coarse`` view, the pixels per cell of a ``cap``
    view; the labels are the seen grid's own path drawn at those pixels per cell (region 30 px, guideline
    2 px, as always), the distance label in the 4 px cells the model perceives."""
    placed = connected_grid(obstacles, start, goal, n)
    if placed is None:
        return None
    blocked, s, g = placed
    px, factor = PX_PER_CELL, 1
    if view is not None and str(view) != "native":
        factor, px = view.factor(n), 0
        blocked = merged_grid(blocked, factor, s, g, view.kind == "walls")
        px = view.px_per_cell(max(blocked.shape))
        s, g = (s[0] // factor, s[1] // factor), (g[0] // factor, g[1] // factor)
        if s == g:
            return None
    img, s_px, g_px = grid_input(blocked, s, g, max(blocked.shape), px)
    region, guide = oracle_prediction(blocked, s, g, px)
    side = img.shape[0]
    r = np.zeros((side, side), bool)
    gl = np.zeros((side, side), bool)
    r[:region.shape[0], :region.shape[1]] = region > 0.5
    gl[:guide.shape[0], :guide.shape[1]] = guide > 0.5
    return Rendered(img, s_px, g_px, gl, r, goal_distance_pixels(blocked, g, side, px))


def unknown_image(unknown: np.ndarray, blocked: np.ndarray, side: int, px: int = PX_PER_CELL) -> np.ndarray:
    """The unknown channel's pixels: the planning cells ``unknown`` that ``blocked`` shows free, ``px`` px per cell,
    padded with known pixels to ``side`` square (a cell believed blocked is known to be: only free cells can
    hide something)."""
    cells = np.asarray(unknown, bool) & ~np.asarray(blocked, bool)
    out = np.zeros((side, side), bool)
    up = np.kron(cells.astype(np.uint8), np.ones((px, px), np.uint8)).astype(bool)
    out[:up.shape[0], :up.shape[1]] = up
    return out


def belief_grids(truth: np.ndarray, believed: np.ndarray, unknown_px: np.ndarray, start: Point, goal: Point,
                 n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, Point, Point] | None:
    """The grids of a belief at ``n`` cells as ``ndrql plan --hide`` builds them (:func:`ndrql.pipeline.belief.plan_grids`,
    no robot radius): ``(true blocked, believed blocked, unknown cells, start cell, goal cell)``, start and goal
    placed on the true map's safe grid and free on the belief's; ``None`` when they fall in one cell or do not
    connect on the truth or on the belief (the plan refuses those)."""
    try:
        tpg = sizing.safe_grid(np.asarray(truth, bool), n, start, goal)
        bpg = sizing.safe_grid(np.asarray(believed, bool), n, start, goal)
    except NoPathError:
        return None
    s, g = tpg.start, tpg.goal
    if s == g or tpg.blocked[s] or tpg.blocked[g] or bfs_distances(tpg.blocked, s)[g] < 0:
        return None
    seen = np.array(bpg.blocked, dtype=bool)
    seen[s] = seen[g] = False
    if bfs_distances(seen, s)[g] < 0:
        return None
    return np.asarray(tpg.blocked, bool), seen, unknown_cells(unknown_px, tpg), s, g


def render_belief_grid(truth: np.ndarray, believed: np.ndarray, unknown_px: np.ndarray, start: Point, goal: Point,
                       n: int) -> Rendered | None:
    """``grid`` mode on a belief (:func:`belief_grids`): the input is the belief's grid (unknown counted free) with
    its unknown cells (:attr:`Rendered.unknown`, :func:`unknown_image`); the labels are the **true** grid's: its
    shortest path drawn as the oracle's arrays and its goal distances. ``None`` when the plan would refuse it."""
    grids = belief_grids(truth, believed, unknown_px, start, goal, n)
    if grids is None:
        return None
    true_blocked, seen, unknown, s, g = grids
    img, s_px, g_px = grid_input(seen, s, g, max(seen.shape))
    region, guide = oracle_prediction(true_blocked, s, g, PX_PER_CELL)
    side = img.shape[0]
    r = np.zeros((side, side), bool)
    gl = np.zeros((side, side), bool)
    r[:region.shape[0], :region.shape[1]] = region > 0.5
    gl[:guide.shape[0], :guide.shape[1]] = guide > 0.5
    return Rendered(img, s_px, g_px, gl, r, goal_distance_pixels(true_blocked, g, side),
                    unknown_image(unknown, seen, side))


def manhattan_pixels(goal_px: Point, side: int) -> np.ndarray:
    """Moves from each cell to the goal's cell on an empty grid (``|dr| + |dc|``), drawn at 4 px per cell on a
    ``side`` square; ``goal_px`` is the goal's pixel. The model's distance head predicts the detour on top of
    it, ``(moves - manhattan) / DISTANCE_UNIT`` (0 wherever walls do not lengthen the way), so that the
    distance is ``manhattan + DISTANCE_UNIT * output``."""
    cells = np.arange(side) // PX_PER_CELL
    gr, gc = goal_px[0] // PX_PER_CELL, goal_px[1] // PX_PER_CELL
    return (np.abs(cells - gr)[:, None] + np.abs(cells - gc)[None, :]).astype(np.float32)


def goal_distance_pixels(blocked: np.ndarray, goal_cell: Point, side: int, px: int = PX_PER_CELL) -> np.ndarray:
    """The ``distance`` label: 4-connected moves from every cell to ``goal_cell`` drawn at ``px`` (4) px per
    cell, in the 4 px cells the model perceives (moves times ``px / 4``), padded with -1 (unknown) to ``side``
    square."""
    cells = bfs_distances(blocked, goal_cell).astype(np.float32)
    cells = np.where(cells >= 0, cells * (px / PX_PER_CELL), -1.0).astype(np.float32)
    out = np.full((side, side), -1.0, np.float32)
    up = np.kron(cells, np.ones((px, px), np.float32))
    out[:up.shape[0], :up.shape[1]] = up
    return out


def cell_means(prob: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Probabilities drawn at 4 px per cell (possibly padded) -> the planning grid of ``shape``: exact 4x4 means."""
    h, w = shape
    return area_downscale(np.asarray(prob, np.float64)[:h * PX_PER_CELL, :w * PX_PER_CELL], (h, w))


def cells_to_map(cells: np.ndarray, shape: tuple[int, int], cell_px: tuple[float, float]) -> np.ndarray:
    """Values per planning cell -> the map's ``shape``: each pixel takes the value of the cell holding its
    centre (cells of ``cell_px`` map pixels, rows and columns)."""
    cells = np.asarray(cells, np.float64)
    r = np.minimum(((np.arange(shape[0]) + 0.5) / cell_px[0]).astype(int), cells.shape[0] - 1)
    c = np.minimum(((np.arange(shape[1]) + 0.5) / cell_px[1]).astype(int), cells.shape[1] - 1)
    return cells[r[:, None], c[None, :]]


def to_map_pixels(prob: np.ndarray, shape: tuple[int, int], n: int) -> np.ndarray:
    """Probabilities at 4 px per cell of a safe grid of ``n`` cells -> the map's pixels: each pixel takes the
    mean of the 4x4 block of the cell holding its centre (:func:`grid_cells_to_map` of :func:`cell_means`)."""
    return grid_cells_to_map(cell_means(prob, grid_shape(shape, n)), shape, n)


def grid_cells_to_map(cells: np.ndarray, shape: tuple[int, int], n: int) -> np.ndarray:
    """Values per cell of the safe grid of ``n`` cells of a map of ``shape`` (``grid_shape(shape, n)`` cells) ->
    the map's pixels: each pixel takes the value of the cell holding its centre (cells of ``max(H, W) / n`` px,
    as :func:`ndrql.maps.safe.conservative_grid`). The cell is found in exact arithmetic,
    ``(i + 0.5) n / max(H, W)``; :func:`cells_to_map` divides by the cell size in pixels instead, which can
    differ for a pixel centre exactly on a cell border (the evaluation scores keep this rule)."""
    rows, cols = grid_shape(shape, n)
    cells = np.asarray(cells, np.float64)
    longest = max(shape)
    r = np.minimum(((np.arange(shape[0]) + 0.5) * n / longest).astype(int), rows - 1)
    c = np.minimum(((np.arange(shape[1]) + 0.5) * n / longest).astype(int), cols - 1)
    return cells[r[:, None], c[None, :]]


def point_on_grid(p: Point, scale: float, side: int) -> Point:
    """Where a pixel centre lands after scaling the map by ``scale`` (clamped to the grid)."""
    return (min(side - 1, int((p[0] + 0.5) * scale)), min(side - 1, int((p[1] + 0.5) * scale)))


def to_model_input(obstacles: np.ndarray, start: Point, goal: Point, side: int = MODEL_SIDE) -> tuple[np.ndarray, Point, Point, float]:
    """Resize/pad a map to ``side`` x ``side`` (module docstring); returns map, start, goal, scale."""
    obstacles = np.asarray(obstacles, bool)
    h, w = obstacles.shape
    if (h, w) == (side, side):
        return obstacles, tuple(start), tuple(goal), 1.0
    scale = side / max(h, w)
    nh, nw = max(1, round(h * scale)), max(1, round(w * scale))
    out = np.ones((side, side), bool)
    out[:nh, :nw] = whole_pixel_majority(obstacles, (nh, nw))
    s = nearest_free_euclidean(out, point_on_grid(tuple(start), nh / h, side))
    g = nearest_free_euclidean(out, point_on_grid(tuple(goal), nh / h, side))
    return out, s, g, scale


def from_model_output(prob: np.ndarray, shape: tuple[int, int], scale: float) -> np.ndarray:
    """Map a (side, side) probability back to the original map's ``shape`` (nearest sampling)."""
    if scale == 1.0 and prob.shape == shape:
        return prob
    h, w = shape
    r = np.minimum(((np.arange(h) + 0.5) * scale).astype(int), prob.shape[0] - 1)
    c = np.minimum(((np.arange(w) + 0.5) * scale).astype(int), prob.shape[1] - 1)
    return prob[r[:, None], c[None, :]]


def render_map(obstacles: np.ndarray, start: Point, goal: Point, waypoints: np.ndarray, n: int) -> Rendered | None:
    """``map`` mode: the map resized to ``4n + 1`` px, the path's waypoints drawn at that scale."""
    side = input_side("map", n)
    img, s, g, scale = to_model_input(obstacles, start, goal, side)
    wp = np.rint((np.asarray(waypoints, np.float64) + 0.5) * scale - 0.5).astype(np.int64)
    wp = np.clip(wp, 0, side - 1)
    guide = draw_guideline((side, side), wp)
    if s == g:
        return None
    return Rendered(img, tuple(s), tuple(g), guide, dilate_region(guide))


def render(mode: str, obstacles: np.ndarray, start: Point, goal: Point, waypoints: np.ndarray | None, n: int,
           view=None) -> Rendered | None:
    """Model input and labels of one map for mode ``mode`` and a grid of ``n`` cells (``None``: unusable);
    ``view``: how a ``grid``-mode model sees a large grid (:func:`render_grid`)."""
    if mode == "grid":
        return render_grid(obstacles, start, goal, n, view)
    if mode == "map":
        if waypoints is None:
            raise NdrqlError("map mode needs the path's waypoints")
        return render_map(obstacles, start, goal, waypoints, n)
    raise NdrqlError(f"unknown input mode {mode!r}; valid: {', '.join(INPUT_MODES)}")
