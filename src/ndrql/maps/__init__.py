"""Maps: the ``GridMap`` type, readers and writers, the 50x50 planning grid and A*.

Coordinates are ``(row, col)`` everywhere inside ndrql; file formats that use ``(x, y)`` are
converted once, in their reader.
"""

from ndrql.maps.astar import AStarResult, astar4, astar8, octile, path_is_valid, shortest_path8
from ndrql.maps.grid import (
    MODEL_SIDE,
    MOVES4,
    PLANNING_SIZE,
    GridMap,
    PlanningGrid,
    SnapWarning,
    area_downscale,
    bfs_distances,
    cell_to_point,
    check_connected,
    grid_to_strings,
    nearest_free_bfs,
    nearest_free_euclidean,
    planning_grid,
    point_to_cell,
)
from ndrql.maps.readers import (
    Scenario,
    load_map,
    read_image,
    read_movingai_map,
    read_movingai_scen,
    read_npy,
    read_ros_yaml,
)
from ndrql.maps.writers import atomic_path, save_map, write_npy, write_png

__all__ = [
    "AStarResult",
    "GridMap",
    "MODEL_SIDE",
    "MOVES4",
    "PLANNING_SIZE",
    "PlanningGrid",
    "SnapWarning",
    "area_downscale",
    "astar4",
    "astar8",
    "shortest_path8",
    "bfs_distances",
    "cell_to_point",
    "check_connected",
    "grid_to_strings",
    "nearest_free_bfs",
    "nearest_free_euclidean",
    "octile",
    "path_is_valid",
    "planning_grid",
    "point_to_cell",
    "Scenario",
    "atomic_path",
    "load_map",
    "read_image",
    "read_movingai_map",
    "read_movingai_scen",
    "read_npy",
    "read_ros_yaml",
    "save_map",
    "write_npy",
    "write_png",
]
