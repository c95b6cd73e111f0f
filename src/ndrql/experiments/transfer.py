"""``ndrql reproduce transfer``: how the model does on maps of every family that it never trained on.

The evaluation sets are versioned (:mod:`ndrql.experiments.eval_sets`); ``transfer`` is a development
set (it was read when choosing the model and the presets); the sealed sets are run by the same code
only through ``ndrql reproduce release`` (:mod:`ndrql.experiments.release`). For every map and planning
grid (default 50 and 100, the safe grid), with the same seeds, the rows of
:data:`~ndrql.experiments.transfer_report.ROWS`: the paper's QL, a tuned QL, IQL, IQL with the exact BFS
distance in Eq. 5, NDR-QL with the model's priors and NDR-QL with the oracle's
(:mod:`ndrql.experiments.ceiling`). A map whose start and goal do not connect on the safe grid of ``n``
cells is planned on the next size of ``--size auto``'s ladder that connects them, up to
``min(2n, 128)`` for ``n <= 100`` and ``min(2n, 512)`` above (:func:`~ndrql.experiments.ceiling.ladder_top`;
so "grid 50" means 50 cells, or 64, 80 or 100 for maps whose passages need them); maps that connect on
none are skipped and counted per family. Above 100 cells the rows without a prior (``QL``, ``QL (tuned)``)
are not run unless ``rows`` asks for them (:func:`~ndrql.experiments.transfer_report.default_rows`).
Per case the wall seconds of each stage are recorded: the prediction (forward pass and drawing on the
grid), the A* and the BFS distance field on the grid, and each row's run (mean over seeds). The figures
are :mod:`ndrql.experiments.transfer_report`'s, the floors and stage times of
:mod:`ndrql.experiments.transfer_floors`.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path
from typing import Callable

import numpy as np

from ndrql.dataset.encodings import encode_input
from ndrql.dataset.generated import GeneratedSet
from ndrql.dataset.render import render
from ndrql.experiments.ceiling import GridCase, grid_case, larger_sizes, model_priors, oracle_priors, prior_arrays
from ndrql.experiments.digests import array_digest, fingerprint
from ndrql.experiments.eval_sets import eval_set, eval_spec
from ndrql.experiments.sweep import Task, run_sweep
from ndrql.experiments.transfer_floors import render_large
from ndrql.experiments.transfer_report import MODEL, ROWS, not_run_note, render_tables, rows_at
from ndrql.io import save_figure, write_json, write_text
from ndrql.maps.grid import PLANNING_SIZE, bfs_distances
from ndrql.model.predict import Predictor
from ndrql.model.symmetry import DEFAULT_COUNT as DEFAULT_SYMMETRIES
from ndrql.model.weights import resolve_weights, weights_label
from ndrql.pipeline.fallback import region_verdict
from ndrql.pipeline.judge import judge
from ndrql.pipeline.sources import drawn_priors
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.preset import Preset, load_preset, method_configs
from ndrql.planning.priors import ThresholdWarning
from ndrql.planning.runner import astar_length, run_plan
from ndrql.training.metrics import f1_per_image
from ndrql.viz.transfer import PredictionPanel, transfer_figure

#: Where the ``QL (tuned)`` row takes its constants: per grid size, the preset whose QL entry was searched
#: for it (``tuned``: 200 trials on the paper's validation maps at 50x50; ``general``: 250 trials on the
#: ``tune`` set at 100x100); a case planned on another size takes the nearest grid's.
TUNED_QL = {50: "tuned", 100: "general"}
BFS_ROW = "IQL (BFS distance)"


def tuned_ql(grid: int | None) -> tuple[QLConfig, PriorConfig]:
    """The constants of the ``QL (tuned)`` row on a grid of ``grid`` cells (:data:`TUNED_QL`)."""
    n = min(TUNED_QL, key=lambda g: (abs(g - (grid or 50)), g))
    return load_preset(TUNED_QL[n]).configs("QL", grid=n)


def row_configs(preset: Preset | None, ql: QLConfig = QLConfig(), pc: PriorConfig = PriorConfig(),
                grid: int | None = None) -> dict[str, tuple[QLConfig, PriorConfig]]:
    """The constants of each row on a grid of ``grid`` cells: the paper's QL takes ``ql``/``pc`` (the
    paper's), the tuned QL :func:`tuned_ql`; the others the preset's entry for their method (of the
    nearest grid size in a per-grid preset; ``ql``/``pc`` without one). Both IQL rows take IQL's, both
    NDR-QL rows NDR-QL's: only their priors differ."""
    out = {row: method_configs(preset, row.split(" ")[0], ql, pc, grid) for row in ROWS}
    out["QL"], out["QL (tuned)"] = (ql, pc), tuned_ql(grid)
    return out


#: The constants of each row on a grid of ``n`` cells (:func:`row_configs` of a preset).
RowConfigs = Callable[[int], dict[str, tuple[QLConfig, PriorConfig]]]


def _runs(blocked, s, g, priors: dict, seeds: list[int], configs: dict[str, tuple[QLConfig, PriorConfig]]) -> dict:
    """Every row of ``priors`` over ``seeds``: per row the steps, convergence and path / A* of each run, the
    threshold, the mean wall seconds of a run (priors and training) and the caps the runs stopped at."""
    out: dict = {}
    opt = astar_length(blocked, s, g)
    for row, pr in priors.items():
        method = "IQL-BFS" if row == BFS_ROW else row.split(" ")[0]  # IQL-BFS: Eq. 5 on the exact BFS distance
        ql, pc = configs[row]
        region, guide, dist = prior_arrays(pr)
        with warnings.catch_warnings():  # the record says it ("threshold": null); one line per map would bury the log
            warnings.simplefilter("ignore", ThresholdWarning)
            runs = [run_plan(blocked, s, g, method, seed, ql, pc, region, guide, distance=dist, astar=opt)
                    for seed in seeds]
        out[row] = {"steps": [int(r.convergence_steps if r.converged else r.total_steps) for r in runs],
                    "converged": [bool(r.converged) for r in runs],
                    "ratio": [float(r.length_ratio) if r.converged and r.length_ratio is not None else None for r in runs],
                    "threshold": runs[0].threshold, "seconds": float(np.mean([r.wall_time for r in runs])),
                    "max_episodes": int(ql.max_episodes), "max_steps": ql.steps_cap(blocked.size)}
    return out


def _timed(fn: Callable, *args):
    """``fn(*args)`` and the wall seconds it took."""
    t0 = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - t0


def grid_seconds(case: GridCase) -> dict[str, float]:
    """Wall seconds of the A* and of the BFS distance field on the case's grid (what ``plan`` computes besides
    the prediction and the runs)."""
    _, astar = _timed(astar_length, case.blocked, case.start_cell, case.goal_cell)
    _, bfs = _timed(bfs_distances, case.blocked, case.goal_cell)
    return {"astar": astar, "bfs": bfs}


def exact_seconds(case: GridCase) -> float:
    """Wall seconds of plan's exact source on the case's grid (:func:`ndrql.pipeline.sources.drawn_priors`), the least
    of three calls (milliseconds at 50 cells, where one call's time is mostly the machine's noise)."""
    return min(_timed(drawn_priors, "exact", case.blocked, case.start_cell, case.goal_cell, None)[1] for _ in range(3))


def _f1(predictor, mode: str, case: GridCase, waypoints, own: bool = False) -> tuple[float, float]:
    """Region and guideline F1 of the model that serves this grid against the labels it trained on here.

    A grid-mode model: the one :meth:`~ndrql.model.predict.Predictor.serving` picks for the case's grid (the
    companion above the base's view limit, as in ``plan``), or with ``own`` the base itself (its second
    opinion served, :func:`~ndrql.pipeline.predictions.predict_on_grid`), on the grid drawn through that
    model's view, its labels drawn the same way (:func:`~ndrql.dataset.render.render_grid`); a map-mode model
    sees the map at 201 px whatever the grid (as in ``ndrql plan``): labels at that scale."""
    if mode == "grid":
        predictor = predictor if own else predictor.serving(case.n)
        r = render("grid", case.obstacles, case.start, case.goal, waypoints, case.n, view=predictor.view)
    else:
        r = render("map", case.obstacles, case.start, case.goal, waypoints, PLANNING_SIZE)
    if r is None:
        return float("nan"), float("nan")
    reg, gl = predictor.predict_batch(encode_input(r.obstacles, r.start, r.goal, predictor.encoding)[None])
    return float(f1_per_image(reg >= 0.5, r.region[None])[0]), float(f1_per_image(gl >= 0.5, r.guideline[None])[0])


def collect(predictor, mode: str, gs: GeneratedSet, grids: tuple[int, ...], seeds: list[int], out: Path, *,
            per_family: int | None = None, configs: RowConfigs | None = None,
            workers: int = 2, executor: str = "process", weights_id: str = "", progress: bool = True,
            grow: bool = True, panels: list[PredictionPanel] | None = None, learned_distance: bool = True,
            rows: tuple[str, ...] | None = None) -> list[dict]:
    """Run every (map, grid) of ``gs`` (at most ``per_family`` maps per family); one record per case.
    ``learned_distance=False``: Eq. 6 on the straight line, as in the paper, even when the weights have a
    distance head (the oracle row then also goes without its exact distance).
    With ``panels``, the first connected case of each family at the first grid is appended to it for the figure.
    ``configs``: the constants of each row on a grid of ``n`` cells, called with the size the case is
    planned on (``lambda n: row_configs(preset, grid=n)``; default the paper's for every row).
    ``rows``: the rows to run on every grid (default :func:`~ndrql.experiments.transfer_report.default_rows`)."""
    configs = configs or (lambda n: row_configs(None))
    picked: dict[str, list[int]] = {}
    for i in range(len(gs)):
        fam = str(gs.families[i])
        if per_family is None or len(picked.setdefault(fam, [])) < per_family:
            picked.setdefault(fam, []).append(i)
    tasks, meta = [], {}
    for n in grids:
        run_rows = rows_at(n, rows)
        for fam, ids in picked.items():
            for i in ids:
                raw = gs.raw(i)
                key = f"{fam}-{i}-g{n}"
                case = grid_case(key, fam, raw.obstacles, raw.start, raw.goal, n, larger_sizes(n) if grow else ())
                if case is None:
                    meta[key] = {"family": fam, "n": n, "skipped": True}
                    continue
                seen: dict = {}
                model, predict_s = _timed(model_priors, predictor, "map201" if mode == "map" else mode, case, seen)  # what plan shows the model
                model = model if learned_distance else model[:2]
                *oracle, bfs = oracle_priors(case, distance=True)  # a perfect version of what the model predicts
                oracle = oracle + [bfs] if len(model) > 2 else oracle
                if panels is not None and n == grids[0] and fam not in {p.family for p in panels}:
                    panels.append(PredictionPanel(fam, case.blocked, case.start_cell, case.goal_cell, model, oracle,
                                                  f"({case.n}x{case.n})"))
                f1 = _f1(predictor, mode, case, raw.waypoints)
                # plan judges the prediction with the paper's threshold schedule whatever the preset (0.99, 0.98, ...)
                judged, cover, _ = region_verdict(np.asarray(model[0]), case.blocked, case.start_cell, case.goal_cell,
                                                  PriorConfig())
                cfg = configs(case.n).get(MODEL, (None, PriorConfig()))[1]  # NDR-QL's constants, as plan judges
                shortest = int(bfs_distances(case.blocked, case.goal_cell)[tuple(case.start_cell)])
                (v_exact, exact_s) = _timed(judge, oracle[0], oracle[1], case.blocked, case.start_cell, case.goal_cell,
                                            cfg, shortest)
                v_model = judge(np.asarray(model[0]), model[1], case.blocked, case.start_cell, case.goal_cell, cfg,
                                shortest)
                meta[key] = {"family": fam, "n": n, "size": case.n, "skipped": False, "f1": f1, "judged_threshold": judged,
                             "region_cover": cover, "verdicts": {"model": v_model.to_dict(), "exact": v_exact.to_dict()},
                             "seconds": {"prediction": predict_s, "exact": exact_seconds(case) + exact_s,
                                         **grid_seconds(case)}}
                priors = {"QL": None, "QL (tuned)": None, "IQL": None, BFS_ROW: None,
                          "NDR-QL (model)": [a.tolist() for a in model], "NDR-QL (oracle)": [a.tolist() for a in oracle]}
                priors = {row: pr for row, pr in priors.items() if row in run_rows}
                grid_id = array_digest(np.packbits(case.blocked))
                prior_id = array_digest(*(np.asarray(a, np.float64) for a in (*model, *oracle)))
                at_n = {row: c for row, c in configs(case.n).items() if row in run_rows}
                fp = fingerprint(key, weights_id, mode, seeds, _configs_id(at_n), case.n, case.blocked.shape, grid_id,
                                 prior_id)
                tasks.append(Task(key, _runs, (case.blocked, case.start_cell, case.goal_cell, priors, seeds, at_n), fp))
    rep = run_sweep(tasks, out / "tasks", executor=executor, workers=workers, progress=progress, desc="transfer")
    return [{"key": k, **m, **({"runs": rep.results[k]} if not m["skipped"] else {})} for k, m in meta.items()]


def _configs_id(configs: dict[str, tuple[QLConfig, PriorConfig]]) -> list:
    """What of the constants goes into a task's fingerprint: every row's values, in row order."""
    return [[row, vars(q), vars(p)] for row, (q, p) in configs.items()]


def transfer(out: str | Path, weights: str | None = None, set_name: str = "transfer", grids: tuple[int, ...] = (50, 100),
             seeds: int = 10, seed0: int = 0, per_family: int | None = None, workers: int = 2, executor: str = "process",
             progress: bool = True, command: str = "", log: Callable[[str], None] = print,
             preset: Preset | None = None, symmetries: int = DEFAULT_SYMMETRIES, learned_distance: bool = True,
             release: bool = False, header: str = "", name: str = "transfer", rows: tuple[str, ...] | None = None) -> Path:
    """Run the transfer report and write ``<name>.md`` and ``summary.json`` under ``out``.

    ``preset``: the constants of each method (``None``: the paper's for every row; a per-grid preset's
    entry nearest to the grid a case is planned on); the oracle row takes NDR-QL's. ``symmetries``: a
    grid-mode model's prediction averaged over that many orientations (``ndrql plan``'s default).
    ``learned_distance``: Eq. 6 on the model's distance when the weights have a distance head (``False``:
    the straight line, the paper's Eq. 6). ``release``: the set may be a sealed one (only
    :mod:`ndrql.experiments.release` passes it); ``header``: a paragraph put first. ``rows``: the rows run on
    every grid (``None``: :func:`~ndrql.experiments.transfer_report.default_rows`, recorded per grid)."""
    out = Path(out)
    wpath = resolve_weights(weights or None)
    predictor = Predictor.load(wpath, threads=1, backend="torch", symmetries=symmetries)
    mode = predictor.input_mode
    gs = eval_set(eval_spec(set_name, release=release), progress, release=release)
    seed_list = list(range(seed0, seed0 + seeds))
    panels: list[PredictionPanel] = []
    configs = lambda n: row_configs(preset, grid=n)  # noqa: E731
    records = collect(predictor, mode, gs, tuple(grids), seed_list, out, per_family=per_family, configs=configs,
                      workers=workers, executor=executor, weights_id=predictor.weights_digest, progress=progress, panels=panels,
                      learned_distance=learned_distance, rows=rows)
    run_rows = {n: rows_at(n, rows) for n in grids}
    constants = "the paper's constants" if preset is None or preset.name == "spec" else \
        f"constants of preset {preset.name!r} (each method its own; the oracle row NDR-QL's)"
    turns = f", averaged over {symmetries} orientations" if mode == "grid" and symmetries > 1 else ""
    eq6 = "Eq. 6 on the model's learned distance if the weights have a distance head" if learned_distance else \
        "Eq. 6 on the straight line, the paper's (--no-learned-distance)"
    role = "sealed set" if release else "development set"
    companion = "" if predictor.merged_weights is None else \
        f"; the grids its view merges served by its companion {predictor.merged_weights.name}"
    merged = {} if predictor.merged_weights is None else {"merged_weights": str(predictor.merged_weights)}
    text = (header + f"Weights {wpath.name} (input mode {mode}{turns}{companion}; {eq6}); {role} {set_name!r} {gs.spec.to_dict()}; "
            f"seeds {seed_list[0]}..{seed_list[-1]}; {constants}.\n\n" + render_tables(records, tuple(grids))
            + render_large(records, tuple(grids)))
    if command:
        text += f"\nCommand: `{command}`\n"
    if panels:
        fig = transfer_figure(sorted(panels, key=lambda p: p.family), Path(weights_label(wpath)).name)
        save_figure(fig, out / "transfer_predictions.png", dpi=110)
        text += "\n![predictions](transfer_predictions.png)\n"
    write_text(out / f"{name}.md", text)
    write_json(out / "summary.json", {"weights": str(wpath), **merged, "mode": mode, "symmetries": symmetries, "set": gs.spec.to_dict(), "seeds": seed_list,
                                      "set_name": set_name, "learned_distance": learned_distance,
                                      "grids": list(grids), "preset": preset.name if preset else "spec",
                                      "rows": {str(n): list(r) for n, r in run_rows.items()},
                                      "rows_not_run": {str(n): not_run_note(n, r) for n, r in run_rows.items()},
                                      "constants": {str(n): {row: {"ql": vars(q), "priors": vars(p)}
                                                             for row, (q, p) in configs(n).items() if row in run_rows[n]}
                                                    for n in grids},
                                      "records": records}, strict=False)
    log(text)
    return out / f"{name}.md"
