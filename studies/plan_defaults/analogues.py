"""End to end on the hand-drawn benchmark analogues (:mod:`ndrql.synth.drawn`, the maps the tests of
``--size auto`` draw): `ndrql.solve` with plan's defaults (NDR-QL, seed 0) on three far-apart free pairs per
map; prints the method, grid size, success, collisions, steps and seconds. The maps come from the package
(same functions, same seeds as tests/maps/test_sizing.py), so the check and the tests see the same maps.

    PYTHONPATH=src nice python studies/plan_defaults/analogues.py
"""
import time, warnings
import ndrql
from ndrql.maps.grid import GridMap
from ndrql.errors import NoPathError
from ndrql.synth.drawn import cave, connected, free_pairs, maze, ros_office, rooms
maps = {"maze 32x2/2 (130 px)": GridMap(maze(32, 2, 2, 32), source="m"), "maze 42x2/1 (127 px)": GridMap(maze(42, 2, 1, 0), source="m"),
        "maze 64x1/1 (129 px)": GridMap(maze(64, 1, 1, 64), source="m"), "maze 85x2/1 (256 px)": GridMap(maze(85, 2, 1, 85), source="m"),
        "rooms 300 px, 2 px doors": GridMap(rooms(300, 60, 2, 3), source="r"), "cave 256 px": GridMap(cave(256, 4), source="c"),
        "office 400x600 @0.1 m": ros_office(400, 600, 0.1, 0.8, 5), "office 300x500 @0.1 m, 1 px doors": ros_office(300, 500, 0.1, 0.1, 5)}
out = []
for name, gm in maps.items():
    for s, g in free_pairs(gm.obstacles, 3, seed=7):
        if not connected(gm.obstacles, s, g):
            out.append((name, s, g, "not connected on the map")); continue
        t = time.time()
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            try:
                rep = ndrql.solve(gm, s, g, "NDR-QL", 1, workers=1)
                r = rep.results[0]
                res = f"{r.method} size {max(rep.grid.shape)} success {r.success} collisions {len(r.route.final_collisions)} steps {r.convergence_steps} {time.time()-t:.0f}s"
            except NoPathError as e:
                res = f"NoPath: {str(e)[:150]}"
        out.append((name, s, g, res)); print(out[-1], flush=True)
