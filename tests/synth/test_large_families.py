"""The large-map families (city, cave, outdoor, corridor_maze, floor, dungeon): one free area, parameters
honoured, labels drawn as for every family, and the helpers they share.

The generic contract (shape, dtype, determinism, obstacle fractions, open free space, any size and aspect
ratio, scale randomised) runs on them with every other family in ``test_families.py``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from ndrql.maps.lines import polyline_collisions
from ndrql.synth import generate_map
from ndrql.synth.families import FAMILIES, LARGE_FAMILIES
from ndrql.synth.generate import SetSpec, generate_sample
from ndrql.synth.labels import dilate_region, draw_guideline
from ndrql.synth.shapes import carve_segments, join_free_areas

from .test_families import maze_lattice

EIGHT = np.ones((3, 3), bool)

#: SHA-256 of samples 0..17 of ``large-dev-128`` (one of each family), when the sets were registered.
PINNED_DEV_128_FIRST_18 = "b9fd328a0cbe39ad49d46393020640162e60a0c8474d8397ba9bedec91db15b8"

#: Families whose free space is one 8-connected area by construction (pockets joined or filled).
ONE_AREA = ("city", "cave", "outdoor", "floor", "dungeon")


def free_areas(m: np.ndarray) -> int:
    return int(ndimage.label(~m, structure=EIGHT)[1])


def test_large_families_are_registered():
    assert LARGE_FAMILIES == ("city", "cave", "outdoor", "corridor_maze", "floor", "dungeon")
    assert all(name in FAMILIES for name in LARGE_FAMILIES)


@pytest.mark.parametrize("name", ONE_AREA)
@pytest.mark.parametrize("size", [96, 512])
def test_free_space_is_one_area(name, size):
    for seed in range(3):
        m = generate_map(name, np.random.default_rng(seed), size, size)
        assert free_areas(m) == 1, (seed, free_areas(m))


@pytest.mark.parametrize("name", LARGE_FAMILIES)
def test_deterministic_at_large_sizes(name):
    a = generate_map(name, np.random.default_rng(11), 600, 480)
    b = generate_map(name, np.random.default_rng(11), 600, 480)
    c = generate_map(name, np.random.default_rng(12), 600, 480)
    assert np.array_equal(a, b) and not np.array_equal(a, c)


@pytest.mark.parametrize("corridor, wall", [(1, 1), (4, 4), (7, 2), (16, 16)])
def test_corridor_maze_corridor_and_wall_are_honoured(corridor, wall):
    m = generate_map("corridor_maze", np.random.default_rng(5), 257, 257, corridor=corridor, wall=wall, loops=0.0)
    grid = maze_lattice(m, corridor, wall)
    n_r, n_c = (grid.shape[0] - 1) // 2, (grid.shape[1] - 1) // 2
    assert (n_r, n_c) == ((257 - wall) // (corridor + wall),) * 2
    passages = (~grid).sum() - n_r * n_c
    assert passages == n_r * n_c - 1  # loops=0: a spanning tree, a perfect maze


def test_corridor_maze_loops_remove_walls():
    """With loops the lattice has more passages than a tree: cycles, and still one free area."""
    m = generate_map("corridor_maze", np.random.default_rng(5), 201, 201, corridor=3, wall=2, loops=0.3)
    grid = maze_lattice(m, 3, 2)
    n = ((grid.shape[0] - 1) // 2) * ((grid.shape[1] - 1) // 2)
    assert (~grid).sum() - n > 1.2 * (n - 1)
    assert free_areas(m) == 1


def test_corridor_maze_one_pixel_corridors_on_a_hand_sized_map():
    """41 px = wall 1 + 20 x (corridor 1 + wall 1): the lattice fills the map; a 4-connected tree of pixels."""
    m = generate_map("corridor_maze", np.random.default_rng(0), 41, 41, corridor=1, wall=1, loops=0.0)
    assert m[0].all() and m[-1].all() and m[:, 0].all() and m[:, -1].all()
    assert not m[1::2, 1::2].any() and m[::2, ::2].all()
    free = ~m
    pairs = (free[:, 1:] & free[:, :-1]).sum() + (free[1:] & free[:-1]).sum()
    assert pairs == free.sum() - 1  # a tree: edges = nodes - 1


def test_cave_rock_share_is_honoured():
    shares = []
    for rock in (0.3, 0.5):
        m = [generate_map("cave", np.random.default_rng(s), 301, 301, rock=rock).mean() for s in range(3)]
        assert all(abs(v - rock) < 0.15 for v in m), (rock, m)
        shares.append(np.mean(m))
    assert shares[0] < shares[1]


@pytest.mark.parametrize("scale", [10, 60])
def test_cave_scale_sets_the_caverns(scale):
    """The widest free spot (largest distance to rock) grows with the caverns' scale."""
    widest = [ndimage.distance_transform_edt(~generate_map("cave", np.random.default_rng(s), 401, 401,
                                                           scale=scale)).max() for s in range(3)]
    assert (np.median(widest) < 16) if scale == 10 else (np.median(widest) > 16), widest


def test_outdoor_is_mostly_free_and_cover_is_honoured():
    low = [generate_map("outdoor", np.random.default_rng(s), 301, 301, cover=0.05).mean() for s in range(3)]
    high = [generate_map("outdoor", np.random.default_rng(s), 301, 301, cover=0.4).mean() for s in range(3)]
    assert max(low) < min(high)
    assert all(0.35 <= v <= 0.6 for v in high), high


@pytest.mark.parametrize("street", [3, 12])
def test_city_streets_are_as_wide_as_asked(street):
    """Some free pixel lies ``street / 2`` px from every building (a street), none much further than a block."""
    m = generate_map("city", np.random.default_rng(2), 400, 400, block=60, street=street)
    d = ndimage.distance_transform_edt(~m)
    assert d.max() >= street / 2
    assert free_areas(m) == 1


def test_city_blocks_grow_with_block():
    small = [generate_map("city", np.random.default_rng(s), 400, 400, block=10, street=3) for s in range(3)]
    large = [generate_map("city", np.random.default_rng(s), 400, 400, block=120, street=3) for s in range(3)]
    count = lambda m: ndimage.label(m)[1]  # noqa: E731  buildings (4-connected obstacle pieces)
    assert np.median([count(m) for m in small]) > 2 * np.median([count(m) for m in large])


def test_dungeon_rooms_and_corridors():
    """Rock everywhere but rooms and corridors: larger rooms give wider free spots; a 1 px corridor exists."""
    widest = {}
    for room in (12, 60):
        maps = [generate_map("dungeon", np.random.default_rng(s), 401, 401, room=room, corridor=1) for s in range(3)]
        widest[room] = np.median([ndimage.distance_transform_edt(~m).max() for m in maps])
        for m in maps:
            assert m.mean() > 0.5 and free_areas(m) == 1
            free = ~m[1:-1, 1:-1]
            across = (m[1:-1, :-2] & m[1:-1, 2:]) | (m[:-2, 1:-1] & m[2:, 1:-1])  # rock on both sides
            assert (free & across).any()
    assert widest[60] > 2 * widest[12], widest


def test_floor_has_an_outer_wall_and_zones():
    m = generate_map("floor", np.random.default_rng(4), 500, 500, aisle=10)
    assert m[0].all() and m[-1].all() and m[:, 0].all() and m[:, -1].all()
    assert 0.015 < m.mean() < 0.35 and free_areas(m) == 1


@pytest.mark.parametrize("name", LARGE_FAMILIES)
def test_labels_as_for_every_family(name):
    """A generated sample of each family: start and goal free, far apart, joined by a collision-free path
    whose guideline and region are drawn by the dataset's definition."""
    raw = generate_sample(SetSpec((name,), (256,), 1, 1234), 0)
    m = raw.obstacles
    assert m.shape == (256, 256) and not m[raw.start] and not m[raw.goal]
    assert np.hypot(raw.start[0] - raw.goal[0], raw.start[1] - raw.goal[1]) >= 0.75 * 256
    wp = np.asarray(raw.waypoints)
    assert tuple(wp[0]) == raw.start and tuple(wp[-1]) == raw.goal
    assert polyline_collisions(m, wp) == []
    guide = draw_guideline(m.shape, wp)
    assert guide[raw.start] and guide[raw.goal]
    region = dilate_region(guide)
    assert (region >= guide).all() and region.sum() > guide.sum()


def test_join_free_areas_on_a_hand_made_map():
    """Two rooms split by a wall, a 1 px pocket: the large room is joined by a corridor, the pocket filled."""
    m = np.ones((20, 30), bool)
    m[2:18, 2:12] = False  # room A (16 x 10)
    m[2:18, 16:28] = False  # room B (16 x 12), the largest
    m[0, 0] = False  # a one-pixel pocket
    out = join_free_areas(m, width=2, min_area=10)
    assert free_areas(out) == 1
    assert out[0, 0]  # filled
    assert not out[2:18, 2:12].any() and not out[2:18, 16:28].any()  # rooms kept
    carved = m & ~out
    assert carved.sum() == 2 * 4  # a 2 px corridor through the 4 px wall
    assert not carved[:, :12].any() and not carved[:, 16:].any()


def test_carve_segments_square_pen():
    mask = carve_segments((10, 10), [((2, 1), (2, 7))], 3)
    assert mask.sum() == 3 * 9 and mask[1:4, 0:9].all()  # rows 1-3, columns 0-8


def first_samples_digest(spec: SetSpec, count: int) -> str:
    """SHA-256 of samples 0..count-1 of ``spec`` as ``studies/large_view/hash_sets.py`` hashes a whole set."""
    from ndrql.io import data_digest

    parts = []
    for i in range(count):
        raw = generate_sample(spec, i)
        parts += [np.packbits(raw.obstacles), np.array([raw.obstacles.shape[0], *raw.start, *raw.goal], np.int64),
                  np.asarray(raw.waypoints, np.int64)]
    return data_digest(*parts)


def test_the_large_sets_are_pinned():
    """The registered large-grid sets hash their maps (``sha256``); a change to any family that would change
    them changes the first sample of that family, one per family here (sample i is family i % 18)."""
    from ndrql.experiments.transfer import eval_spec

    spec = eval_spec("large-dev-128")
    assert spec.seed == 900101 and len(spec.families) == 18 and set(LARGE_FAMILIES) <= set(spec.families)
    assert first_samples_digest(spec, 18) == PINNED_DEV_128_FIRST_18
