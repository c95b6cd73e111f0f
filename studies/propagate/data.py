"""Small planning grids with the cells of their shortest routes: the data of the propagation probe.

Sample ``i`` of a seed draws a family map (round-robin over the eighteen families) at 2-4 px per cell,
start and goal as the generated sets draw them, the safe grid of ``n`` cells as ``plan`` builds it, and the
target: every free cell on some 4-connected shortest route (``d_start + d_goal == d*``).
"""

from __future__ import annotations

import sys
from multiprocessing import Pool
from pathlib import Path

import numpy as np

from ndrql.dataset.render import connected_grid
from ndrql.maps.grid import bfs_distances
from ndrql.synth.endpoints import sample_endpoints
from ndrql.synth.families import family_names, generate_map

CACHE = Path.home() / ".cache" / "ndrql" / "propagate"


def on_route(blocked: np.ndarray, s: tuple[int, int], g: tuple[int, int]) -> np.ndarray:
    """Free cells on some 4-connected shortest route from ``s`` to ``g``."""
    ds, dg = bfs_distances(blocked, s), bfs_distances(blocked, g)
    best = ds[g]
    return (ds >= 0) & (dg >= 0) & (ds + dg == best)


def one_path(blocked: np.ndarray, s: tuple[int, int], g: tuple[int, int]) -> np.ndarray:
    """The free cells within one move of one shortest 4-connected path (A*'s, its own tie-breaking): a target that
    narrows where :func:`on_route` fills a whole rectangle of open space."""
    from scipy import ndimage

    from ndrql.maps.astar import astar4

    out = np.zeros(blocked.shape, bool)
    for r, c in astar4(blocked, s, g).path:
        out[r, c] = True
    return ndimage.binary_dilation(out, structure=ndimage.generate_binary_structure(2, 1)) & ~np.asarray(blocked, bool)


def sample(seed: int, i: int, cells: tuple[int, ...], target: str = "routes") -> tuple[np.ndarray, tuple, tuple, np.ndarray] | None:
    """``(blocked, start, goal, target)`` of sample ``i`` (``target`` ``routes``: :func:`on_route`; ``path``:
    :func:`one_path`), or ``None`` when the draw does not connect."""
    fams = family_names()
    rng = np.random.default_rng([seed, i])
    n = int(cells[int(rng.integers(len(cells)))])
    px = n * int(rng.integers(2, 5))
    for _ in range(10):
        occ = generate_map(fams[i % len(fams)], rng, px, px)
        pair = sample_endpoints(rng, occ)
        if pair is None:
            continue
        placed = connected_grid(occ, tuple(map(int, pair[0])), tuple(map(int, pair[1])), n)
        if placed is None:
            continue
        blocked, s, g = placed
        return blocked, s, g, (one_path if target == "path" else on_route)(blocked, s, g)
    return None


def _one(args):
    return sample(*args)


def build(seed: int, count: int, cells: tuple[int, ...], target: str = "routes", workers: int = 2) -> list:
    with Pool(workers) as pool:
        out = pool.map(_one, [(seed, i, cells, target) for i in range(count)], chunksize=64)
    return [o for o in out if o is not None]


def save(path: Path, samples: list) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, blocked=np.array([s[0] for s in samples], dtype=object),
                        start=np.array([s[1] for s in samples]), goal=np.array([s[2] for s in samples]),
                        route=np.array([s[3] for s in samples], dtype=object))


if __name__ == "__main__":
    seed, count = int(sys.argv[1]), int(sys.argv[2])
    cells = tuple(int(c) for c in sys.argv[3].split(","))
    target = sys.argv[4] if len(sys.argv) > 4 else "routes"
    out = build(seed, count, cells, target)
    save(CACHE / f"seed{seed}-{count}-{sys.argv[3]}{'' if target == 'routes' else '-' + target}.npz", out)
    print(len(out), "samples")
