"""The map engine's families: contract, determinism, obstacle fractions, open free space, known answers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from ndrql.errors import NdrqlError
from ndrql.synth import FAMILIES, Family, family_names, generate_map
from ndrql.synth.layouts import perfect_maze, recursive_division
from ndrql.synth.shapes import feature_px, is_open, paint_rects, stamp

SIZES = [(201, 201), (401, 401), (150, 300)]

#: Obstacle fraction every draw of a family stays in (over seeds 0..4 at SIZES).
FRACTION = {
    "blocks": (0.06, 0.35),
    "gaps": (0.002, 0.6),
    "bugtrap": (0.002, 0.3),
    "bugtraps": (0.005, 0.35),
    "gaps_blocks": (0.05, 0.65),
    "narrow_passage": (0.02, 0.65),
    "maze": (0.05, 0.8),
    "rooms": (0.01, 0.35),
    "office": (0.03, 0.55),
    "scatter": (0.045, 0.36),
    "warehouse": (0.05, 0.75),
    "ros_scan": (0.28, 0.75),
    "city": (0.2, 0.65),
    "cave": (0.38, 0.62),
    "outdoor": (0.1, 0.42),
    "corridor_maze": (0.1, 0.75),
    "floor": (0.015, 0.3),
    "dungeon": (0.65, 0.9),
}


def spans_halves(obstacles: np.ndarray) -> bool:
    """The brief's condition, written independently: the largest 8-connected free component has pixels
    in the top and the bottom half and in the left and the right half."""
    labels, n = ndimage.label(~obstacles, structure=np.ones((3, 3)))
    if n == 0:
        return False
    counts = np.bincount(labels.ravel())
    counts[0] = 0
    rows, cols = np.nonzero(labels == counts.argmax())
    h, w = obstacles.shape
    return bool(rows.min() < h / 2 <= rows.max() and cols.min() < w / 2 <= cols.max())


def test_registry_lists_every_family_with_a_docstring():
    assert family_names() == tuple(FAMILIES) == tuple(FRACTION)
    for name, fam in FAMILIES.items():
        assert isinstance(fam, Family) and fam.name == name
        assert fam.summary and "\n" not in fam.summary
        assert "Randomises" in (fam.generate.__doc__ or "")
    with pytest.raises(Exception):
        FAMILIES["maze"].name = "x"  # frozen


@pytest.mark.parametrize("name", list(FRACTION))
@pytest.mark.parametrize("shape", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
def test_family_contract(name, shape):
    lo, hi = FRACTION[name]
    maps = [generate_map(name, np.random.default_rng(seed), *shape) for seed in range(5)]
    for seed, m in enumerate(maps):
        assert m.shape == shape and m.dtype == bool
        assert lo <= m.mean() <= hi, (seed, m.mean())
        assert spans_halves(m), seed
        assert is_open(m), seed
    again = generate_map(name, np.random.default_rng(0), *shape)
    assert np.array_equal(again, maps[0])
    assert not np.array_equal(maps[0], maps[1])
    assert len({m.tobytes() for m in maps}) == 5


@pytest.mark.parametrize("name", list(FRACTION))
def test_family_draws_from_the_given_generator_only(name):
    """Calling the family function directly with a generator in a known state gives the registry's map."""
    a = FAMILIES[name].generate(np.random.default_rng(7), 120, 90)
    np.random.seed(1)  # the global state must not matter
    b = generate_map(name, np.random.default_rng(7), 120, 90)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("name", list(FRACTION))
@pytest.mark.parametrize("shape", [(16, 16), (64, 900), (900, 64), (64, 64)], ids=lambda s: f"{s[0]}x{s[1]}")
def test_any_size_and_aspect_ratio(name, shape):
    for seed in range(3):
        m = generate_map(name, np.random.default_rng(seed), *shape)
        assert m.shape == shape and m.dtype == bool
        assert spans_halves(m)


@pytest.mark.parametrize("name", list(FRACTION))
def test_scale_is_randomised(name):
    """The typical distance from a free pixel to the nearest obstacle varies by at least 1.5x over 8 seeds."""
    scale = []
    for seed in range(8):
        m = generate_map(name, np.random.default_rng(seed), 401, 401)
        scale.append(ndimage.distance_transform_edt(~m)[~m].mean())
    assert max(scale) >= 1.5 * min(scale), scale


def test_unknown_family_lists_valid_names():
    with pytest.raises(NdrqlError) as info:
        generate_map("labyrinth", np.random.default_rng(0), 100, 100)
    message = str(info.value)
    assert "labyrinth" in message and "\n" not in message
    for name in family_names():
        assert name in message


@pytest.mark.parametrize("kwargs, fragment", [
    ({"name": "maze", "height": 8, "width": 100}, "height"),
    ({"name": "maze", "height": 100, "width": 100.5}, "width"),
    ({"name": "maze", "height": 100, "width": 100, "corridors": 3}, "corridor, wall"),
    ({"name": "scatter", "height": 100, "width": 100, "density": 1.5}, "density"),
    ({"name": "maze", "height": 30, "width": 30, "corridor": 29}, "no room"),
    ({"name": "blocks", "height": 50, "width": 50, "size": "big"}, "integer"),
    ({"name": "maze", "height": 50, "width": 50, "corridor": 2.5}, "integer"),
    ({"name": "scatter", "height": 50, "width": 50, "density": "dense"}, "number"),
    ({"name": "ros_scan", "height": 50, "width": 50, "outside": float("nan")}, "outside"),
])
def test_bad_arguments_raise_one_line_errors(kwargs, fragment):
    kwargs = dict(kwargs)
    name = kwargs.pop("name")
    with pytest.raises(NdrqlError) as info:
        generate_map(name, np.random.default_rng(0), **kwargs)
    assert fragment in str(info.value) and "\n" not in str(info.value)


def test_rng_must_be_a_generator():
    with pytest.raises(NdrqlError, match="Generator"):
        generate_map("maze", 0, 100, 100)


def maze_lattice(m: np.ndarray, corridor: int, wall: int) -> np.ndarray:
    """The coarse wall grid behind a maze image, asserting that every lattice block is uniform."""
    rows, cols = np.nonzero(~m)
    r0, c0 = rows.min() - wall, cols.min() - wall
    pitch = corridor + wall
    n_r, n_c = (rows.max() + 1 - r0) // pitch, (cols.max() + 1 - c0) // pitch
    assert m[:r0].all() and m[:, :c0].all()
    assert m[r0 + wall + n_r * pitch:].all() and m[:, c0 + wall + n_c * pitch:].all()
    edges_r = np.cumsum([r0] + [wall, corridor] * n_r + [wall])
    edges_c = np.cumsum([c0] + [wall, corridor] * n_c + [wall])
    grid = np.zeros((len(edges_r) - 1, len(edges_c) - 1), dtype=bool)
    for i in range(grid.shape[0]):
        for j in range(grid.shape[1]):
            block = m[edges_r[i]:edges_r[i + 1], edges_c[j]:edges_c[j + 1]]
            assert block.all() or not block.any(), (i, j)  # uniform: corridors exactly `corridor` wide
            grid[i, j] = block.all()
    return grid


@pytest.mark.parametrize("shape, corridor, wall", [((23, 23), 5, 2), ((30, 47), 3, 1), ((120, 90), 9, 4)])
def test_maze_corridor_and_wall_are_honoured(shape, corridor, wall):
    m = generate_map("maze", np.random.default_rng(3), *shape, corridor=corridor, wall=wall)
    grid = maze_lattice(m, corridor, wall)
    n_r, n_c = (grid.shape[0] - 1) // 2, (grid.shape[1] - 1) // 2
    assert (n_r, n_c) == ((shape[0] - wall) // (corridor + wall), (shape[1] - wall) // (corridor + wall))
    assert not grid[1::2, 1::2].any()  # cells are free
    assert grid[::2, ::2].all()  # wall joints are walls
    assert grid[0].all() and grid[-1].all() and grid[:, 0].all() and grid[:, -1].all()
    passages = (~grid).sum() - n_r * n_c
    assert passages == n_r * n_c - 1  # a spanning tree: perfect
    assert ndimage.label(~m)[1] == 1


def test_maze_hand_checked_23px():
    """23 px = wall 2 + 3 x (corridor 5 + wall 2): the lattice fills the map exactly, no offset."""
    m = generate_map("maze", np.random.default_rng(0), 23, 23, corridor=5, wall=2)
    assert m[:2].all() and m[-2:].all() and m[:, :2].all() and m[:, -2:].all()
    for r in (2, 9, 16):
        for c in (2, 9, 16):
            assert not m[r:r + 5, c:c + 5].any()  # the 9 cells, 5x5 each
    for r in (0, 7, 14, 21):
        for c in (0, 7, 14, 21):
            assert m[r:r + 2, c:c + 2].all()  # wall joints
    for line in list(m[2:21]) + list(m[:, 2:21].T):  # every straight free run: 1, 2 or 3 cells and the passages between
        edges = np.flatnonzero(np.diff(np.concatenate([[1], line.view(np.int8), [1]])))
        runs = set(edges[1::2] - edges[::2])
        assert runs <= {5, 12, 19}, runs


def test_perfect_maze_is_a_spanning_tree():
    grid = perfect_maze(np.random.default_rng(1), 9, 14, bias=0.5)
    assert grid.shape == (19, 29)
    assert (~grid).sum() - 9 * 14 == 9 * 14 - 1
    assert ndimage.label(~grid)[1] == 1
    assert not np.array_equal(grid, perfect_maze(np.random.default_rng(2), 9, 14, bias=0.5))


@pytest.mark.parametrize("density", [0.05, 0.15, 0.3])
@pytest.mark.parametrize("shape", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
def test_scatter_density_is_honoured(density, shape):
    for seed in range(4):
        m = generate_map("scatter", np.random.default_rng(seed), *shape, density=density)
        assert abs(m.mean() - density) <= 0.012, (seed, m.mean())


def test_scatter_size_bounds_the_obstacles():
    m = generate_map("scatter", np.random.default_rng(0), 300, 300, density=0.05, size=4, squares=1.0)
    labels, n = ndimage.label(m)
    boxes = ndimage.find_objects(labels)
    singles = [b for b in boxes if b[0].stop - b[0].start <= 4 and b[1].stop - b[1].start <= 4]
    assert len(singles) > 0.6 * n  # most squares stand alone and are at most 4 px across


def test_rooms_every_room_reachable():
    """Recursive division never puts a wall end on a door: the whole free space is one component."""
    for seed in range(20):
        m = generate_map("rooms", np.random.default_rng(seed), 301, 257)
        assert ndimage.label(~m)[1] == 1, seed


def test_recursive_division_doors_on_a_hand_made_box():
    out = np.zeros((40, 40), dtype=bool)
    out[0], out[-1], out[:, 0], out[:, -1] = True, True, True, True
    recursive_division(np.random.default_rng(5), out, (1, 1, 39, 39), room=8, wall=1, door=3, stop_p=0.0)
    assert out[1:39, 1:39].any()  # at least one wall
    assert ndimage.label(~out)[1] == 1


def test_is_open_on_hand_made_maps():
    free = np.zeros((40, 60), dtype=bool)
    assert is_open(free)
    wall = free.copy()
    wall[20, :] = True  # cuts the map in two halves
    assert not is_open(wall)
    wall[20, 30:34] = False  # a gap joins them
    assert is_open(wall)
    corner = np.ones((40, 60), dtype=bool)
    corner[:15, :15] = False  # only the top-left quadrant is free
    assert not is_open(corner)


@pytest.mark.parametrize("largest", [4, 30], ids=["small-pixelwise", "large-difference-array"])
def test_paint_rects_matches_slicing(largest):
    rng = np.random.default_rng(0)
    rects = rng.integers(-10, 110, size=(200, 4))
    rects[:, 2:] = rects[:, :2] + rng.integers(0, largest, size=(200, 2))
    expected = np.zeros((100, 80), dtype=bool)
    for r0, c0, r1, c1 in rects:
        expected[max(r0, 0):max(r1, 0), max(c0, 0):max(c1, 0)] = True
    assert np.array_equal(paint_rects((100, 80), rects), expected)  # > 64 rectangles
    assert np.array_equal(paint_rects((100, 80), rects[:5]), np.logical_or.reduce(  # a few: slicing
        [paint_rects((100, 80), rects[i:i + 1]) for i in range(5)]))


def test_stamp_clips_at_the_border():
    mask = np.zeros((5, 5), dtype=bool)
    stamp(mask, np.array([-1, 3]), np.array([-1, 3]), np.ones((3, 3), dtype=bool))
    expected = np.zeros((5, 5), dtype=bool)
    expected[:2, :2] = True
    expected[3:, 3:] = True
    assert np.array_equal(mask, expected)


def test_feature_px_ranges():
    rng = np.random.default_rng(0)
    small = [feature_px(rng, 201, px=(4, 500), rel=(0.004, 0.15)) for _ in range(300)]
    large = [feature_px(rng, 2000, px=(4, 500), rel=(0.004, 0.15)) for _ in range(300)]
    assert 4 <= min(small) and max(small) <= 30  # 0.15 x 201; the 0.8 px lower end is clipped to 4
    assert min(large) <= 12 and 150 <= max(large) <= 300  # 8..300 px: relatively finer and coarser
