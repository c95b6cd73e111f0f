"""``ndrql predict``: region and guideline of the optimal path, predicted by the NDR model."""

from __future__ import annotations

import argparse
from pathlib import Path

from ndrql.cli.astar_cmd import add_grid_arguments, grid_request
from ndrql.cli.common import (add_dpi_argument, add_max_pixels_argument, add_problem_arguments, add_symmetries_argument,
                              add_weights_argument, check_dpi, save_figure, warnings_to_stderr)
from ndrql.cli.options import add_command
from ndrql.dataset.render import cells_to_map
from ndrql.dataset.views import view_note
from ndrql.errors import NdrqlError
from ndrql.io import make_folder, save_npz
from ndrql.model.predict import BACKENDS, load_predictor
from ndrql.model.symmetry import DEFAULT_COUNT
from ndrql.pipeline.predictions import prediction_arrays, predict_region, view_prediction
from ndrql.pipeline.problem import build_grid, grid_text
from ndrql.viz.prediction import plot_distance_field, plot_probability_overlay

EXAMPLES = """examples:
  ndrql predict --sample path-planning-dataset:unseen:600 --out out/pred
  ndrql predict map.png --start 20,30 --goal 180,170 --out out/pred --weights my_model.pt
"""


def register(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "predict", help="predict the path region and guideline with the NDR model",
                    description="Predict the optimal path's region and guideline (probabilities) with the NDR model; "
                    "writes region.png, guideline.png (overlays), distance.png (a model with a distance head) and "
                    "prediction.npz (arrays at the map's size and, from "
                    "a grid-mode model, on the planning grid it saw: ndrql plan --prior-from prediction.npz then plans "
                    "on that grid exactly as with the model).",
                    examples=EXAMPLES)
    add_problem_arguments(p)
    add_max_pixels_argument(p)
    add_weights_argument(p)
    p.add_argument("--out", metavar="DIR", default="out/predict", help="output folder (default: out/predict)")
    p.add_argument("--backend", choices=BACKENDS, default="auto",
                   help="inference backend: auto (ONNX Runtime when installed, else torch), onnx or torch (default: auto)")
    p.add_argument("--threads", type=int, default=1, metavar="N", help="threads for the forward pass (default: 1)")
    add_grid_arguments(p, "the grid ndrql plan builds: auto on a map file, 50 with --sample; map-mode models see "
                       "the map itself and refuse --size", rule=False)
    add_symmetries_argument(p, "grid-mode models: average the prediction over N orientations of the grid (1, 2, 4, 8), "
                            "as ndrql plan does", DEFAULT_COUNT)
    add_dpi_argument(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import time

    import numpy as np

    dpi = check_dpi(args)
    request = grid_request(args, size=args.size, robot_radius=args.robot_radius, threads=args.threads,
                           backend=args.backend, symmetries=args.symmetries)
    settings = request.settings
    with warnings_to_stderr():
        pg, setup = build_grid(request.grid_map, request.start, request.goal, settings)  # the grid plan builds
    existed = Path(args.out).exists()
    out = make_folder(args.out)  # before the model runs: a file in the way is one clear line
    obstacles = request.grid_map.obstacles
    t0 = time.perf_counter()
    predictor = load_predictor(args.weights, settings.threads, settings.backend, settings.symmetries)
    t1 = time.perf_counter()
    if predictor.input_mode != "grid" and args.size is not None:
        raise NdrqlError(f"--size chooses the grid a grid-mode model sees; {args.weights or 'the weights'} hold a "
                         f"map-mode model (it sees the map at 201 px): drop --size")
    try:
        with warnings_to_stderr():
            view = predict_region(predictor, request.grid_map, pg, request.start, request.goal)
    except Exception:
        if not existed:
            out.rmdir()  # made above and still empty: leave nothing behind
        raise
    pred = view_prediction(view, pg, setup.size)
    t2 = time.perf_counter()
    npz = out / "prediction.npz"
    arrays = {**prediction_arrays(pred), "start": np.array(request.start), "goal": np.array(request.goal),
              "obstacles": obstacles}
    save_npz(npz, arrays)
    written = [npz]
    h, w = obstacles.shape
    size = (5.2, min(9.0, max(2.5, 4.4 * h / w)) + 1.0)  # room for the colour bar and the legend below
    for name, prob in (("region", pred.region), ("guideline", pred.guideline)):
        if prob is None:
            continue
        written.append(save_figure(lambda ax, prob=prob, name=name: plot_probability_overlay(
            ax, obstacles, prob, kind=name, start=request.start, goal=request.goal,
            title=f"NDR {name} ({setup.rule} grid {pg.shape[0]}x{pg.shape[1]})"),
            out / f"{name}.png", figsize=size, dpi=dpi))
    if pred.grid is not None and pred.grid.distance is not None:
        dist_map = cells_to_map(pred.grid.distance, obstacles.shape, pg.cell_size)
        written.append(save_figure(lambda ax: plot_distance_field(
            ax, obstacles, dist_map, start=request.start, goal=request.goal, title="NDR distance to the goal"),
            out / "distance.png", figsize=size, dpi=dpi))
    print(grid_text(setup, pg, request.grid_map.resolution))
    if pred.grid is not None:
        seen = view_note(view.info.get("view", "native"), int(view.info.get("merged", 1)), " through the view ")
        companion = f"; served by the companion {view.info['weights_file']}" if view.info.get("companion") else ""
        print(f"grid-mode model: saw the {setup.rule} {pg.shape[0]}x{pg.shape[1]} planning grid plan builds, at 4 px "
              f"per cell{seen}, start cell {pg.start}, goal cell {pg.goal}{companion}")
    else:
        print("map-mode model: saw the map resized to 201 px (the grid is plan's, for the record)")
    print(f"{predictor.backend_name}: load {1000 * (t1 - t0):.0f} ms, predict {1000 * (t2 - t1):.0f} ms; "
          f"region > 0.5: {int((pred.region >= 0.5).sum())} px" +
          (f", guideline > 0.5: {int((pred.guideline >= 0.5).sum())} px" if pred.guideline is not None else ""))
    for path in written:
        print(f"wrote {path}")
    return 0
