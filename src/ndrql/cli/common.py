"""Helpers shared by the subcommands: map and point arguments, dataset samples, JSON/PNG output.

A subcommand that plans on a map calls :func:`add_problem_arguments` on its parser and
:func:`resolve_problem` on the parsed namespace; it gets a :class:`~ndrql.maps.problem.GridMapProblem`
(map, start, goal in source pixels, and a description for reports). Every bad input raises an
:class:`~ndrql.errors.NdrqlError` subclass, which the dispatcher prints as one line (exit code 2).
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, Iterator

from ndrql.dataset.layout import load_sample
from ndrql.errors import DatasetError, NdrqlError, PointError
from ndrql.io import check_writable, json_text, save_figure as io_save_figure, write_json as io_write_json
from ndrql.limits import check_finite, check_int
from ndrql.maps.bundled import bundled_sample
from ndrql.maps.grid import Cell, GridMap
from ndrql.maps.problem import GridMapProblem
from ndrql.maps.readers import MAX_MAP_PIXELS, load_map
from ndrql.model.weights import DEFAULT_WEIGHTS, SHIPPED_WEIGHTS
from ndrql.model.symmetry import COUNTS as SYMMETRY_COUNTS
from ndrql.viz.maps import new_figure
from ndrql.viz.style import DEFAULT_DPI

SAMPLE_SPLITS = ("train", "seen", "unseen")


def parse_point(text: str, name: str = "point") -> Cell:
    """Parse ``"row,col"`` (integers, spaces allowed) into ``(row, col)``; :class:`PointError` otherwise."""
    shown = repr(str(text)[:40]) + ("..." if len(str(text)) > 40 else "")
    parts = [p.strip() for p in str(text).split(",", 2)]
    if len(parts) != 2 or not all(len(p) <= 12 and p.isascii() for p in parts):  # ASCII digits only
        raise PointError(f"{name} must be ROW,COL (two integers), got {shown}")
    try:
        return (int(parts[0]), int(parts[1]))
    except ValueError:
        raise PointError(f"{name} must be ROW,COL (two integers), got {shown}") from None


def parse_scen(text: str) -> tuple[str, int | None]:
    """Parse ``--scen FILE[:K]`` into ``(FILE, K)`` (``K`` is ``None`` when not given).

    A trailing ``:K`` is the scenario number when ``K`` is an integer (sign allowed, at most 12
    characters) and ``FILE:K`` itself is not a file; the caller checks ``K`` against the file.
    """
    head, sep, tail = str(text).rpartition(":")
    if sep and tail.strip().lstrip("+-").isdigit() and len(tail) <= 12 and not Path(text).is_file():
        return head, int(tail)
    return str(text), None


def parse_sample_spec(text: str) -> tuple[Path, str, int]:
    """Parse ``DATASET_DIR:SPLIT:INDEX`` (split = train|seen|unseen); the directory may contain ``:``."""
    parts = str(text).rsplit(":", 2)
    if len(parts) != 3 or not parts[0]:
        raise DatasetError(f"--sample must be DATASET_DIR:SPLIT:INDEX, got {text!r}")
    root, split, index = parts
    split = split.strip().lower()
    if split not in SAMPLE_SPLITS:
        raise DatasetError(f"unknown split {split!r} in --sample; valid: {', '.join(SAMPLE_SPLITS)}")
    try:
        idx = int(index)
    except ValueError:
        raise DatasetError(f"sample index must be an integer, got {index!r}") from None
    return Path(root), split, idx


def load_sample_problem(spec: str) -> GridMapProblem:
    """Map, start and goal of a dataset sample given as ``DATASET_DIR:SPLIT:INDEX``."""
    root, split, index = parse_sample_spec(spec)
    if not root.is_dir():
        raise DatasetError(f"dataset directory not found: {root} (get it with git clone "
                           f"https://github.com/JimOriginal/path-planning-dataset)")
    sample = load_sample(root, split, index)
    source = f"{root}:{split}:{index}"
    grid_map = GridMap(sample.map, source=source)
    info = {
        "source": source,
        "sample": {"root": str(root), "split": split, "index": index, "category": sample.category,
                   "map_index": sample.map_index, "rrt_cost": sample.cost},
    }
    return GridMapProblem.of(grid_map, tuple(sample.start), tuple(sample.goal), info)  # type: ignore[arg-type]


def add_map_arguments(parser: argparse.ArgumentParser, *, map_required: bool = False) -> None:
    """``MAP`` (any supported format) or ``--sample DATASET_DIR:SPLIT:INDEX``, plus reader options."""
    parser.add_argument("map", nargs=None if map_required else "?", metavar="MAP",
                        help="map file: image (.png .jpg .pgm .bmp), ROS map_server .yaml, MovingAI .map, or .npy")
    if not map_required:
        parser.add_argument("--sample", metavar="DATASET_DIR:SPLIT:INDEX",
                            help="a dataset sample instead of MAP (split: train|seen|unseen); supplies start and goal")
        parser.add_argument("--example", action="store_true",
                            help="the bundled 201x201 example map instead of MAP, with its recorded start and goal "
                                 "(--start/--goal override them); prints where the map is installed")
    parser.add_argument("--invert", action="store_true", help="images: light pixels are obstacles")
    parser.add_argument("--threshold", type=float, default=128, metavar="V",
                        help="images: gray value below which a pixel is dark (default: 128)")
    parser.add_argument("--crop", action="store_true", help="ROS maps: crop to the bounding box of known cells")


def add_weights_argument(parser: argparse.ArgumentParser, default: str | None = None) -> None:
    """``--weights paper|general|belief|FILE``; ``default`` names the shipped weights used without it."""
    names = "|".join(SHIPPED_WEIGHTS)
    parser.add_argument("--weights", metavar=f"{names}|FILE",
                        help=f"NDR model weights: shipped {', '.join(list(SHIPPED_WEIGHTS)[:-1])} or "
                             f"{list(SHIPPED_WEIGHTS)[-1]}, or a checkpoint file (planning "
                             "also takes an .onnx graph from export-onnx) "
                             f"(default: $NDRQL_WEIGHTS, else {default or DEFAULT_WEIGHTS})")


def add_max_pixels_argument(parser: argparse.ArgumentParser) -> None:
    """``--max-pixels N``: the largest map read (refused from its header before decoding)."""
    parser.add_argument("--max-pixels", type=int, default=MAX_MAP_PIXELS, metavar="N",
                        help=f"refuse maps with more pixels than this (default: {MAX_MAP_PIXELS:,} = 4096 x 4096)")


def add_problem_arguments(parser: argparse.ArgumentParser) -> None:
    """Map arguments plus ``--start ROW,COL`` and ``--goal ROW,COL`` (source-map pixels)."""
    add_map_arguments(parser)
    parser.add_argument("--start", metavar="ROW,COL", help="start in map pixels (row, col); overrides a sample's")
    parser.add_argument("--goal", metavar="ROW,COL", help="goal in map pixels (row, col); overrides a sample's")


def load_map_argument(args: argparse.Namespace) -> GridMapProblem | GridMap:
    """The map named by ``args``: a :class:`GridMapProblem` for ``--sample``, else a :class:`GridMap`.

    A map larger than ``args.max_pixels`` (when the subcommand has that flag, else the readers'
    default of 4096 x 4096) is refused before it is decoded.
    """
    sample = getattr(args, "sample", None)
    if getattr(args, "example", False):
        use_example(args, bool(sample))
    if sample and args.map:
        raise NdrqlError("give either MAP or --sample, not both")
    if sample:
        return load_sample_problem(sample)
    if not args.map:
        raise NdrqlError("no map given: pass MAP, --example (the bundled map) or --sample DATASET_DIR:SPLIT:INDEX")

    max_pixels = check_int(getattr(args, "max_pixels", MAX_MAP_PIXELS), "--max-pixels", 1)
    check_finite(args.threshold, "--threshold")
    return load_map(args.map, invert=args.invert, threshold=args.threshold, crop=args.crop, max_pixels=max_pixels)


def use_example(args: argparse.Namespace, sample: bool) -> None:
    """``--example``: ``args.map`` becomes the bundled map's installed path and its recorded start and goal
    fill ``--start``/``--goal`` when neither they nor world points are given; one stderr line says where."""
    if args.map or sample:
        raise NdrqlError("give one of MAP, --sample and --example")
    ex = bundled_sample()
    where = ex.grid_map.source  # the installed map file
    rel = os.path.relpath(where) if Path(where).resolve().is_relative_to(Path.cwd().resolve()) else where
    args.map = rel  # as a user would type it from here: reports name the map as given
    for name, point in (("start", ex.start), ("goal", ex.goal)):
        if hasattr(args, name) and not getattr(args, name) and not getattr(args, f"{name}_world", None):
            setattr(args, name, f"{point[0]},{point[1]}")
    print(f"ndrql: example map {where} ({ex.grid_map.height}x{ex.grid_map.width}), start {ex.start[0]},{ex.start[1]}, "
          f"goal {ex.goal[0]},{ex.goal[1]} (row, col)", file=sys.stderr)


def resolve_problem(args: argparse.Namespace) -> GridMapProblem:
    """Map, start and goal from ``MAP --start --goal`` or ``--sample`` (whose points ``--start``/``--goal`` override)."""
    loaded = load_map_argument(args)
    if isinstance(loaded, GridMapProblem):
        start = parse_point(args.start, "--start") if args.start else loaded.start
        goal = parse_point(args.goal, "--goal") if args.goal else loaded.goal
        problem = GridMapProblem.of(loaded.grid_map, start, goal, loaded.info)
    else:
        missing = [flag for flag in ("--start", "--goal") if not getattr(args, flag[2:])]
        if missing:
            raise PointError(f"{' and '.join(missing)} required with a map file (ROW,COL in map pixels)")
        problem = GridMapProblem.of(loaded, parse_point(args.start, "--start"), parse_point(args.goal, "--goal"),
                                    {"source": loaded.source})
    for name, point in (("start", problem.start), ("goal", problem.goal)):
        if not problem.grid_map.contains(point):
            h, w = problem.grid_map.shape
            raise PointError(f"{name} {point[0]},{point[1]} is off the map (rows 0..{h - 1}, cols 0..{w - 1})")
        if problem.grid_map.obstacles[point]:  # the same rule as `plan` (ndrql.api.check_points)
            raise PointError(f"{name} {point[0]},{point[1]} is on an obstacle of the map")
    return problem


def map_info(grid_map: GridMap) -> dict[str, Any]:
    """Size, obstacle ratio and (for ROS maps) resolution/origin of a map, JSON-ready."""
    info: dict[str, Any] = {
        "source": grid_map.source,
        "height": grid_map.height,
        "width": grid_map.width,
        "obstacle_ratio": round(grid_map.obstacle_ratio, 6),
    }
    if grid_map.resolution is not None:
        info["resolution"] = grid_map.resolution
    if grid_map.origin is not None:
        info["origin"] = list(grid_map.origin)
    return info


def write_json(path: str | Path, data: Any) -> Path:
    """Write ``data`` as indented JSON through :func:`ndrql.io.write_json` (``-`` writes to stdout)."""
    if str(path) == "-":
        if sys.stdout is None:
            raise NdrqlError("standard output is closed; give --json a file name")
        sys.stdout.write(json_text(data) + "\n")
        return Path("-")
    return io_write_json(path, data)


def check_outputs(*paths: str | Path | None) -> None:
    """Fail before the work starts when an output file could not be written (``None`` and ``-`` are skipped)."""
    for path in paths:
        if path is not None and str(path) != "-":
            check_writable(path)


def add_dpi_argument(parser: argparse.ArgumentParser) -> None:
    """``--dpi N``: the resolution of the command's figures (:data:`ndrql.viz.style.DEFAULT_DPI` by default)."""
    parser.add_argument("--dpi", type=int, default=DEFAULT_DPI, metavar="N",
                        help=f"figure resolution in dots per inch, {MIN_DPI}..{MAX_DPI} (default: {DEFAULT_DPI})")


def add_symmetries_argument(parser: argparse.ArgumentParser, help_text: str, default: int) -> None:
    """``--symmetries N``: average a grid-mode model's prediction over N orientations (:mod:`ndrql.model.symmetry`)."""
    parser.add_argument("--symmetries", type=int, choices=SYMMETRY_COUNTS, default=default, metavar="N",
                        help=f"{help_text} (default: {default})")


#: Range of ``--dpi``.
MIN_DPI, MAX_DPI = 30, 600


def check_dpi(args: argparse.Namespace) -> int:
    """``args.dpi`` checked against :data:`MIN_DPI`..:data:`MAX_DPI` (the style's default when the command has no flag)."""
    return check_int(getattr(args, "dpi", DEFAULT_DPI), "--dpi", MIN_DPI, MAX_DPI)


def save_figure(draw: Callable[[Any], Any], path: str | Path, figsize: tuple[float, float] = (6.0, 6.0), dpi: int = 110) -> Path:
    """Create an Agg figure, call ``draw(ax)``, save it through :func:`ndrql.io.save_figure` (format from the extension)."""
    fig = new_figure(figsize=figsize, dpi=dpi)
    ax = fig.add_subplot(1, 1, 1)
    draw(ax)
    fig.tight_layout()
    return io_save_figure(fig, path)


@contextmanager
def warnings_to_stderr() -> Iterator[None]:
    """Show warnings raised inside the block as ``ndrql: warning: ...`` lines on stderr."""
    failed = True
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        try:
            yield
            failed = False
        finally:
            seen = set()
            for w in caught:
                msg = str(w.message)
                ours = f"{os.sep}ndrql{os.sep}" in str(w.filename)
                if msg not in seen and (ours or not failed):  # a failed command: only ndrql's own warnings
                    seen.add(msg)
                    print(f"ndrql: warning: {msg}", file=sys.stderr)


def add_path_out_arguments(group: Any) -> None:
    """``--path-out`` and ``--path-spacing`` (plan and astar: the one nav_msgs/Path writer)."""
    group.add_argument("--path-out", metavar="FILE", help="write the final path as a nav_msgs/Path (frame map, poses "
                       "with quaternions): YAML for .yaml/.yml, else JSON (ROS maps)")
    group.add_argument("--path-spacing", type=float, default=None, metavar="M",
                       help="--path-out: at most M metres between poses (default: the map's resolution, a pose per map "
                            "cell as Nav2's planners publish; 0: only the path's corners)")


def add_batch_group(parser: Any, verb: str) -> None:
    """The scenario batch's flags (plan and astar; ``verb``: what is done to a scenario, "run" or "search")."""
    batch = parser.add_argument_group("batch: every scenario of a .scen")
    batch.add_argument("--index", default=None, metavar="K|A:B", help=f"scenario number in --scen (0-based); A:B "
                       f"{verb}s scenarios A..B-1 in a batch")
    batch.add_argument("--all", action="store_true", help=f"{verb} every scenario of --scen: one line each and a "
                       "summary against the .scen optimal lengths")
    batch.add_argument("--jsonl", metavar="FILE", help="batch (--all, --index A:B): append one JSON record per scenario "
                       "(fields: docs/cli.md); scenarios already in FILE are skipped (resume)")


def map_or_sample(args: Any) -> Any:
    """The dataset sample of ``--sample`` (``None`` for a map file), after the checks plan and astar share: MAP
    and ``--sample`` not both, ``--scen`` only with a map file, some map given (``--example`` fills MAP)."""
    if args.example:
        use_example(args, bool(args.sample))
    if args.sample and args.map:
        raise NdrqlError("give either MAP or --sample, not both")
    sample = load_sample_problem(args.sample) if args.sample else None
    if sample is not None and args.scen:
        raise NdrqlError("--scen needs a map file (MovingAI .map), not --sample")
    if sample is None and not args.map:
        raise NdrqlError("no map given: pass MAP, --example (the bundled map) or --sample DATASET_DIR:SPLIT:INDEX")
    return sample
