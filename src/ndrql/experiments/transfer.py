"""``ndrql reproduce transfer``: how the model does on maps of every family that it never trained on.

The evaluation set is versioned (``transfer_sets.json``: families, map sizes, count and a seed that
training never uses); it is generated into the cache on first use, deterministically. For every
map and planning grid (default 50 and 100, the safe grid), with the same seeds: QL, IQL, NDR-QL with
the model's priors and NDR-QL with the oracle's (:mod:`ndrql.experiments.ceiling`). Reported per
family and pooled: region/guideline F1 of the model against the labels of its own input mode,
NDR-QL vs QL and vs IQL (pooled steps, and the share of maps where NDR-QL needs fewer steps than
IQL), greedy path / A*, the share of maps where the Eq. 7 threshold had to fall below 0.5, and the
model's share of the oracle's reduction. A map whose start and goal do not connect on the safe grid
of ``n`` cells is planned on the next size of ``--size auto``'s ladder that connects them, up to
``min(2n, 128)`` (so "grid 50" means 50 cells, or 64, 80 or 100 for maps whose passages need them);
maps that connect on none are skipped and counted.
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ndrql.dataset.cache import cache_dir
from ndrql.dataset.encodings import encode_input
from ndrql.dataset.generated import GeneratedSet, generate_set, read_manifest
from ndrql.dataset.render import render
from ndrql.errors import NdrqlError
from ndrql.experiments.ceiling import GridCase, grid_case, model_priors, oracle_priors, prior_arrays
from ndrql.experiments.report import md_table
from ndrql.experiments.stats import share_of_oracle, wilson_interval
from ndrql.experiments.digests import array_digest, fingerprint
from ndrql.experiments.sweep import Task, run_sweep
from ndrql.io import file_digest, save_figure, write_json, write_text
from ndrql.maps.grid import PLANNING_SIZE
from ndrql.model.predict import Predictor
from ndrql.model.symmetry import DEFAULT_COUNT as DEFAULT_SYMMETRIES
from ndrql.model.weights import resolve_weights, weights_label
from ndrql.pipeline.predictions import MIN_THRESHOLD
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.preset import Preset, method_configs
from ndrql.planning.priors import adaptive_threshold
from ndrql.planning.runner import run_plan
from ndrql.synth.generate import SetSpec
from ndrql.training.metrics import f1_per_image
from ndrql.viz.transfer import PredictionPanel, transfer_figure

ROWS = ("QL", "IQL", "NDR-QL (model)", "NDR-QL (oracle)")


def eval_spec(name: str = "transfer") -> SetSpec:
    """The versioned evaluation set ``name`` of ``transfer_sets.json``."""
    data = json.loads(resources.files("ndrql.experiments").joinpath("transfer_sets.json").read_text())
    if name not in data["sets"]:
        raise NdrqlError(f"unknown evaluation set {name!r}; valid: {', '.join(data['sets'])}")
    return SetSpec.from_dict(data["sets"][name])


def eval_set(spec: SetSpec, progress: bool = True) -> GeneratedSet:
    """The evaluation set in the cache (generated on first use; same spec, same bytes)."""
    root = cache_dir() / "gen" / f"eval-{fingerprint(spec.to_dict())}"
    if not (root / "manifest.json").exists() or read_manifest(root)["spec"] != spec.to_dict():
        generate_set(root, spec, workers=2, progress=progress)
    return GeneratedSet.load(root)


def row_configs(preset: Preset | None, ql: QLConfig = QLConfig(), pc: PriorConfig = PriorConfig(),
                grid: int | None = None) -> dict[str, tuple[QLConfig, PriorConfig]]:
    """The constants of each row on a grid of ``grid`` cells: ``ql``/``pc`` for all without a preset; with
    one, each method's entry (of the nearest grid size in a per-grid preset; the oracle row takes
    NDR-QL's: only its priors differ from the model row)."""
    return {row: method_configs(preset, row.split(" ")[0], ql, pc, grid) for row in ROWS}


#: The constants of each row on a grid of ``n`` cells (:func:`row_configs` of a preset).
RowConfigs = Callable[[int], dict[str, tuple[QLConfig, PriorConfig]]]


def _runs(blocked, s, g, priors: dict, seeds: list[int], configs: dict[str, tuple[QLConfig, PriorConfig]]) -> dict:
    out: dict = {}
    for row, pr in priors.items():
        method = row.split(" ")[0]
        region, guide, dist = prior_arrays(pr)
        ql, pc = configs[row]
        runs = [run_plan(blocked, s, g, method, seed, ql, pc, region, guide, distance=dist) for seed in seeds]
        out[row] = {"steps": [int(r.convergence_steps if r.converged else r.total_steps) for r in runs],
                    "converged": [bool(r.converged) for r in runs],
                    "ratio": [float(r.length_ratio) if r.converged and r.length_ratio is not None else None for r in runs],
                    "threshold": runs[0].threshold}
    return out


def _f1(predictor, mode: str, case: GridCase, waypoints) -> tuple[float, float]:
    """Region and guideline F1 of the model against the labels of its input mode at this grid."""
    # map-mode models see the map at 201 px whatever the grid (as in ndrql plan): labels at that scale
    r = render("grid", case.obstacles, case.start, case.goal, waypoints, case.n) if mode == "grid" else \
        render("map", case.obstacles, case.start, case.goal, waypoints, PLANNING_SIZE)
    if r is None:
        return float("nan"), float("nan")
    reg, gl = predictor.predict_batch(encode_input(r.obstacles, r.start, r.goal, predictor.encoding)[None])
    return float(f1_per_image(reg >= 0.5, r.region[None])[0]), float(f1_per_image(gl >= 0.5, r.guideline[None])[0])


def collect(predictor, mode: str, gs: GeneratedSet, grids: tuple[int, ...], seeds: list[int], out: Path, *,
            per_family: int | None = None, configs: RowConfigs | None = None,
            workers: int = 2, executor: str = "process", weights_id: str = "", progress: bool = True,
            grow: bool = True, panels: list[PredictionPanel] | None = None) -> list[dict]:
    """Run every (map, grid) of ``gs`` (at most ``per_family`` maps per family); one record per case.
    With ``panels``, the first connected case of each family at the first grid is appended to it for the figure.
    ``configs``: the constants of each row on a grid of ``n`` cells, called with the size the case is
    planned on (``lambda n: row_configs(preset, grid=n)``; default the paper's for every row)."""
    configs = configs or (lambda n: row_configs(None))
    picked: dict[str, list[int]] = {}
    for i in range(len(gs)):
        fam = str(gs.families[i])
        if per_family is None or len(picked.setdefault(fam, [])) < per_family:
            picked.setdefault(fam, []).append(i)
    tasks, meta = [], {}
    for n in grids:
        for fam, ids in picked.items():
            for i in ids:
                raw = gs.raw(i)
                key = f"{fam}-{i}-g{n}"
                case = grid_case(key, fam, raw.obstacles, raw.start, raw.goal, n, larger_sizes(n) if grow else ())
                if case is None:
                    meta[key] = {"family": fam, "n": n, "skipped": True}
                    continue
                model = model_priors(predictor, "map201" if mode == "map" else mode, case)  # what plan shows the model
                oracle = oracle_priors(case, distance=len(model) > 2)  # a perfect version of what the model predicts
                if panels is not None and n == grids[0] and fam not in {p.family for p in panels}:
                    panels.append(PredictionPanel(fam, case.blocked, case.start_cell, case.goal_cell, model, oracle,
                                                  f"({case.n}x{case.n})"))
                f1 = _f1(predictor, mode, case, raw.waypoints)
                # plan judges the prediction with the paper's threshold schedule whatever the preset (0.99, 0.98, ...)
                judged = adaptive_threshold(np.asarray(model[0]), case.blocked, case.start_cell, case.goal_cell, PriorConfig())
                meta[key] = {"family": fam, "n": n, "size": case.n, "skipped": False, "f1": f1, "judged_threshold": judged}
                priors = {"QL": None, "IQL": None, "NDR-QL (model)": [a.tolist() for a in model],
                          "NDR-QL (oracle)": [a.tolist() for a in oracle]}
                grid_id = array_digest(np.packbits(case.blocked))
                prior_id = array_digest(*(np.asarray(a, np.float64) for a in (*model, *oracle)))
                at_n = configs(case.n)
                fp = fingerprint(key, weights_id, mode, seeds, _configs_id(at_n), case.n, case.blocked.shape, grid_id,
                                 prior_id)
                tasks.append(Task(key, _runs, (case.blocked, case.start_cell, case.goal_cell, priors, seeds, at_n), fp))
    rep = run_sweep(tasks, out / "tasks", executor=executor, workers=workers, progress=progress, desc="transfer")
    return [{"key": k, **m, **({"runs": rep.results[k]} if not m["skipped"] else {})} for k, m in meta.items()]


def _configs_id(configs: dict[str, tuple[QLConfig, PriorConfig]]) -> list:
    """What of the constants goes into a task's fingerprint: every row's values, in row order."""
    return [[row, vars(q), vars(p)] for row, (q, p) in configs.items()]


def larger_sizes(n: int) -> tuple[int, ...]:
    """Sizes tried after ``n`` when a map does not connect at ``n``: the auto ladder up to ``min(2n, 128)``."""
    from ndrql.maps.sizing import SIZE_LADDER  # lazy: loads numba

    return tuple(s for s in SIZE_LADDER if n < s <= min(2 * n, 128))


def _pooled(records: list[dict], row: str) -> float:
    return float(sum(sum(r["runs"][row]["steps"]) for r in records))


def judged_threshold(record: dict) -> float | None:
    """The Eq. 7 threshold by which ``ndrql plan`` judges the prediction: the highest of the paper's
    schedule (0.99 in steps of 0.01) at which the region joins start and goal, whatever threshold
    schedule the preset's NDR-QL runs use (records written before it was stored: the run's own)."""
    if "judged_threshold" in record:
        return record["judged_threshold"]
    return record["runs"]["NDR-QL (model)"]["threshold"]


def plan_steps(record: dict, cut: float = MIN_THRESHOLD) -> list[int]:
    """The steps ``ndrql plan`` would spend on this case for NDR-QL: the model row's where the judged
    Eq. 7 threshold (:func:`judged_threshold`) is at least ``cut`` (plan's
    :data:`~ndrql.pipeline.predictions.MIN_THRESHOLD`), else IQL's (plan's default fallback for an
    uninformative prediction; its other test, the guideline's mass on obstacles, is not applied here)."""
    thd = judged_threshold(record)
    row = "NDR-QL (model)" if thd is not None and thd >= cut else "IQL"
    return record["runs"][row]["steps"]


def _against_iql(records: list[dict], row: str) -> tuple[int, int, int]:
    """:func:`against_iql` of ``row``'s and IQL's mean steps per map (means over the seeds)."""
    return against_iql(*([np.mean(r["runs"][k]["steps"]) for r in records] for k in (row, "IQL")))


def _wins_over_iql(records: list[dict], row: str) -> int:
    """Maps on which ``row`` needs fewer steps than IQL (means over the seeds)."""
    return _against_iql(records, row)[0]


def _beats_iql(records: list[dict], row: str) -> float:
    """Share of the maps on which ``row`` needs fewer steps than IQL (means over the seeds)."""
    return _wins_over_iql(records, row) / len(records)


#: Relative gap in mean steps within which a map counts as a tie with IQL in :func:`_ties_and_losses`.
TIE = 0.005


def against_iql(ndr: Sequence[float], iql: Sequence[float], tie: float = TIE) -> tuple[int, int, int]:
    """Maps won (fewer mean steps than IQL), tied (within ``tie`` relative, either side) and lost by more,
    from per-map mean steps. On a map where both follow a shortest route from the first episode, both
    need about ``W`` times its length and a few exploration moves decide which is lower: *beats IQL*
    counts such a map either way, the tie count tells it apart from a clear loss."""
    gap = np.asarray(ndr, float) / np.asarray(iql, float) - 1
    return int((gap < 0).sum()), int((np.abs(gap) <= tie).sum()), int((gap > tie).sum())


def _ties_and_losses(records: list[dict], row: str) -> tuple[float, float]:
    """Shares of the maps ``row`` ties with IQL and loses by more (:func:`against_iql`)."""
    _, tied, lost = _against_iql(records, row)
    return tied / len(records), lost / len(records)


def summarize(records: list[dict]) -> dict:
    """Pooled and per-map figures of a group of case records (same seeds in every row)."""
    ok = [r for r in records if not r["skipped"]]
    if not ok:
        return {"maps": 0, "skipped": len(records)}
    ql = _pooled(ok, "QL")
    plan = float(sum(sum(plan_steps(r)) for r in ok))
    red = {row: 1 - _pooled(ok, row) / ql for row in ROWS}
    ratios = [x for r in ok for x in r["runs"]["NDR-QL (model)"]["ratio"] if x is not None]
    thd = [judged_threshold(r) for r in ok]
    ties, losses = _ties_and_losses(ok, "NDR-QL (model)")
    return {
        "maps": len(ok), "skipped": len(records) - len(ok),
        "grown": int(sum(r.get("size", r["n"]) != r["n"] for r in ok)),
        "region_f1": 100 * float(np.nanmean([r["f1"][0] for r in ok])),
        "guideline_f1": 100 * float(np.nanmean([r["f1"][1] for r in ok])),
        "vs_ql": {row: -red[row] for row in ROWS},
        "vs_iql": _pooled(ok, "NDR-QL (model)") / _pooled(ok, "IQL") - 1,
        "beats_iql": _beats_iql(ok, "NDR-QL (model)"),
        "beats_iql_ci": list(wilson_interval(_wins_over_iql(ok, "NDR-QL (model)"), len(ok))),
        "oracle_beats_iql": _beats_iql(ok, "NDR-QL (oracle)"),
        "ties_iql": ties,
        "loses_to_iql": losses,
        "path_ratio": float(np.mean(ratios)) if ratios else float("nan"),
        "threshold_below_half": float(np.mean([t is None or t < 0.5 for t in thd])),
        "not_converged": int(sum(not c for r in ok for c in r["runs"]["NDR-QL (model)"]["converged"])),
        "plan_vs_ql": plan / ql - 1,
        "plan_vs_iql": plan / _pooled(ok, "IQL") - 1,
        "plan_worse_than_iql": float(np.mean([np.mean(plan_steps(r)) > np.mean(r["runs"]["IQL"]["steps"]) for r in ok])),
        "share": share_of_oracle(*([sum(r["runs"][row]["steps"]) for r in ok] for row in (*ROWS[2:], "QL"))),
    }


def _share_cell(s: dict, with_ci: bool) -> str:
    """The 'beats IQL' cell: the share, and for the pooled row its 95% Wilson interval."""
    lo, hi = s["beats_iql_ci"]
    return f"{100 * s['beats_iql']:.0f}%" + (f" ({100 * lo:.0f}-{100 * hi:.0f})" if with_ci else "")


def render_tables(records: list[dict], grids: tuple[int, ...]) -> str:
    """Markdown: one table per grid, a row per family and a pooled row."""
    parts = []
    head = ["family", "maps (finer grid; skipped)", "region F1", "guideline F1", "NDR-QL vs QL", "oracle vs QL", "share of oracle",
            "NDR-QL vs IQL", "beats IQL", f"ties IQL (±{100 * TIE:.1f}%)",
            "loses to IQL", "oracle beats IQL", "path / A*", "Eq. 7 thd < 0.5", "plan vs QL", "plan vs IQL", "plan worse than IQL"]
    for n in grids:
        at_n = [r for r in records if r["n"] == n]
        rows = []
        for fam in sorted({r["family"] for r in at_n}) + ["all"]:
            s = summarize([r for r in at_n if fam == "all" or r["family"] == fam])
            if not s["maps"]:
                rows.append([fam, f"0 ({s['skipped']})"] + ["-"] * (len(head) - 2))
                continue
            rows.append([f"**{fam}**" if fam == "all" else fam, f"{s['maps']} ({s['grown']}; {s['skipped']})", f"{s['region_f1']:.1f}",
                         f"{s['guideline_f1']:.1f}", f"{100 * s['vs_ql']['NDR-QL (model)']:+.1f}%",
                         f"{100 * s['vs_ql']['NDR-QL (oracle)']:+.1f}%", f"{100 * s['share']:.0f}%", f"{100 * s['vs_iql']:+.1f}%",
                         _share_cell(s, fam == "all"), f"{100 * s['ties_iql']:.0f}%", f"{100 * s['loses_to_iql']:.0f}%",
                         f"{100 * s['oracle_beats_iql']:.0f}%", f"{s['path_ratio']:.3f}", f"{100 * s['threshold_below_half']:.0f}%",
                         f"{100 * s['plan_vs_ql']:+.1f}%", f"{100 * s['plan_vs_iql']:+.1f}%",
                         f"{100 * s['plan_worse_than_iql']:.0f}%"])
        finer = ", ".join(map(str, larger_sizes(n)))
        parts.append(f"**Planning grid {n}** (safe grid; maps that need it on {finer or 'no finer size'})\n\n" + md_table(head, rows))
    parts.append(f"*plan*: what `ndrql plan` spends for NDR-QL with its default fallback: the model's run where the "
                 f"Eq. 7 threshold is at least {MIN_THRESHOLD}, IQL's where the prediction does not connect start and "
                 f"goal at that level; *worse than IQL*: maps where that costs more steps than IQL (mean over seeds); "
                 f"*oracle beats IQL*: the same count for NDR-QL with the oracle's priors (what a perfect prediction "
                 f"reaches with these constants); in brackets after the pooled *beats IQL*, its 95% Wilson interval "
                 f"over the maps; *ties IQL*: maps where NDR-QL's mean steps are within {100 * TIE:.1f}% of IQL's (counted "
                 f"as won or lost in *beats IQL* by a few exploration moves), *loses to IQL*: more than {100 * TIE:.1f}% "
                 f"above them.")
    return "\n\n".join(parts) + "\n"


def transfer(out: str | Path, weights: str | None = None, set_name: str = "transfer", grids: tuple[int, ...] = (50, 100),
             seeds: int = 10, seed0: int = 0, per_family: int | None = None, workers: int = 2, executor: str = "process",
             progress: bool = True, command: str = "", log: Callable[[str], None] = print,
             preset: Preset | None = None, symmetries: int = DEFAULT_SYMMETRIES) -> Path:
    """Run the transfer report and write ``transfer.md`` and ``summary.json`` under ``out``.

    ``preset``: the constants of each method (``None``: the paper's for every row; a per-grid preset's
    entry nearest to the grid a case is planned on); the oracle row takes NDR-QL's. ``symmetries``: a
    grid-mode model's prediction averaged over that many orientations (``ndrql plan``'s default)."""
    out = Path(out)
    wpath = resolve_weights(weights or None)
    predictor = Predictor.load(wpath, threads=1, backend="torch", symmetries=symmetries)
    mode = predictor.input_mode
    gs = eval_set(eval_spec(set_name), progress)
    seed_list = list(range(seed0, seed0 + seeds))
    panels: list[PredictionPanel] = []
    configs = lambda n: row_configs(preset, grid=n)  # noqa: E731
    records = collect(predictor, mode, gs, tuple(grids), seed_list, out, per_family=per_family, configs=configs,
                      workers=workers, executor=executor, weights_id=file_digest(wpath), progress=progress, panels=panels)
    constants = "the paper's constants" if preset is None or preset.name == "spec" else \
        f"constants of preset {preset.name!r} (each method its own; the oracle row NDR-QL's)"
    turns = f", averaged over {symmetries} orientations" if mode == "grid" and symmetries > 1 else ""
    text = (f"Weights {wpath.name} (input mode {mode}{turns}); evaluation set {set_name!r} {gs.spec.to_dict()}; "
            f"seeds {seed_list[0]}..{seed_list[-1]}; {constants}.\n\n" + render_tables(records, tuple(grids)))
    if command:
        text += f"\nCommand: `{command}`\n"
    if panels:
        fig = transfer_figure(sorted(panels, key=lambda p: p.family), Path(weights_label(wpath)).name)
        save_figure(fig, out / "transfer_predictions.png", dpi=110)
        text += "\n![predictions](transfer_predictions.png)\n"
    write_text(out / "transfer.md", text)
    write_json(out / "summary.json", {"weights": str(wpath), "mode": mode, "symmetries": symmetries, "set": gs.spec.to_dict(), "seeds": seed_list,
                                      "grids": list(grids), "preset": preset.name if preset else "spec",
                                      "constants": {str(n): {row: {"ql": vars(q), "priors": vars(p)}
                                                             for row, (q, p) in configs(n).items()} for n in grids},
                                      "records": records}, strict=False)
    log(text)
    return out / "transfer.md"
