"""Planning problems for ``ndrql tune --maps generated``: held-out generated maps on the safe grid.

The search behind the ``general`` preset runs on the versioned evaluation set ``tune``
(``transfer_sets.json``: every family, 201/401/801 px, a seed no training set and no reported set
uses), on the planning grid that ``ndrql reproduce transfer`` and ``ndrql plan`` build: the safe grid
of ``n`` cells, or the next size of the auto ladder that connects start and goal (up to
``min(2n, 128)``). The problems are taken family by family in turn (the first connected map of every
family, then the second, ...), so that ``k`` problems cover every family alike; each carries the
model's priors on its grid, made the way ``plan`` makes them for the weights' input mode.
"""

from __future__ import annotations

from pathlib import Path

from ndrql.experiments.ceiling import case_problem, grid_case, larger_sizes, model_priors
from ndrql.experiments.eval_sets import eval_set, tuning_spec
from ndrql.model.predict import Predictor
from ndrql.model.symmetry import DEFAULT_COUNT as DEFAULT_SYMMETRIES
from ndrql.model.symmetry import digest_suffix
from ndrql.model.weights import resolve_weights
from ndrql.pipeline.samples import Problem

#: The evaluation set the per-grid searches use.
TUNE_SET = "tune"


def interleave(by_family: dict[str, list[int]], k: int) -> list[tuple[str, int]]:
    """The first ``k`` of ``(family, index)`` taken family by family in turn (families in sorted order)."""
    out: list[tuple[str, int]] = []
    depth = max((len(v) for v in by_family.values()), default=0)
    for r in range(depth):
        for fam in sorted(by_family):
            if r < len(by_family[fam]) and len(out) < k:
                out.append((fam, by_family[fam][r]))
    return out


def generated_problems(k: int, n: int, weights: str | Path | None = None, set_name: str = TUNE_SET,
                       progress: bool = False, symmetries: int = DEFAULT_SYMMETRIES) -> tuple[list[Problem], list[str], str]:
    """``k`` problems of set ``set_name`` on the safe grid of ``n`` cells with the model's priors (module
    docstring; a grid-mode model averaged over ``symmetries`` orientations, as ``plan`` does); also the
    keys of the maps skipped as disconnected on every size tried, and the first 16 hex digits of the
    weights' SHA-256 (with ``-s<symmetries>`` when not 1)."""
    from tqdm import tqdm

    gs = eval_set(tuning_spec(set_name), progress)
    cases, skipped, by_family = {}, [], {}
    for i in tqdm(range(len(gs)), desc=f"grids {n}", unit="map", disable=not progress):
        raw, fam = gs.raw(i), str(gs.families[i])
        case = grid_case(f"{set_name}-g{n}-{i}", fam, raw.obstacles, raw.start, raw.goal, n, larger_sizes(n))
        if case is None:
            skipped.append(f"{set_name}-g{n}-{i}")
            continue
        cases[i] = case
        by_family.setdefault(fam, []).append(i)
    wpath = resolve_weights(None if weights is None else str(weights))
    predictor = Predictor.load(wpath, threads=1, backend="torch", symmetries=symmetries)
    mode = "map201" if predictor.input_mode == "map" else predictor.input_mode
    out = []
    for fam, i in tqdm(interleave(by_family, k), desc="predictions", unit="map", disable=not progress):
        c = cases[i]
        out.append(case_problem(c, f"{set_name}-g{n}", i, model_priors(predictor, mode, c)))
    return out, skipped, predictor.weights_digest[:16] + digest_suffix(symmetries)
