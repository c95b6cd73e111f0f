"""The transfer report at large grids, by hand: the geometric mean with plan's fallback, the oracle's share of
the gain over IQL in geometric means, capped runs that win nothing, the rows run per grid (no QL rows above
100 cells unless asked), the size ladder above 128 cells and the floors block's met / missed lines."""

from __future__ import annotations

import json

import pytest

from ndrql.errors import NdrqlError
from ndrql.experiments import eval_sets, transfer_report as tr
from ndrql.experiments.ceiling import larger_sizes, ladder_top
from ndrql.experiments.eval_sets import parse_registry
from ndrql.experiments.transfer_floors import capped_runs, floors, render_large, stage_medians
from ndrql.experiments.transfer_report import (ROWS, default_rows, not_run_note, parse_rows, render_tables,
                                               summarize)


def _row(steps: list[int], converged: list[bool] | None = None, seconds: float = 0.01) -> dict:
    conv = converged or [True] * len(steps)
    return {"steps": steps, "converged": conv, "ratio": [1.1 if c else None for c in conv], "threshold": None,
            "seconds": seconds, "max_episodes": 20000, "max_steps": 4 * 128 * 128}


def _record(key: str, fam: str, thd: float | None, iql: list[int], ndr: list[int], oracle: list[int], n: int = 128,
            predict_s: float = 0.3, ndr_converged: list[bool] | None = None) -> dict:
    """A planned case at grid ``n`` with the rows run above 100 cells (no QL rows)."""
    return {"key": key, "family": fam, "n": n, "size": n, "skipped": False, "f1": (0.8, 0.5), "judged_threshold": thd,
            "seconds": {"prediction": predict_s, "astar": 0.01, "bfs": 0.02},
            "runs": {"IQL": _row(iql), "IQL (BFS distance)": _row(iql), "NDR-QL (model)": _row(ndr, ndr_converged),
                     "NDR-QL (oracle)": _row(oracle)}}


def _three(n: int = 128, thd_b: float | None = None, **kw) -> list[dict]:
    return [_record("a1", "rooms", 0.6, [1000, 1000], [400, 400], [300, 300], n, **kw),
            _record("a2", "rooms", 0.5, [2000, 2000], [500, 500], [400, 400], n, **kw),
            _record("b1", "maze", thd_b, [800, 800], [1600, 1600], [400, 400], n, **kw)]


def test_the_fallback_geomean_and_the_oracle_share_by_hand():
    s = summarize(_three())
    # per-map NDR / IQL: 0.4, 0.25, 2.0; b1's prediction joins start and goal at no threshold: plan runs IQL (1.0)
    assert s["rows"]["NDR-QL (model)"]["vs_iql"]["ratio"] == pytest.approx(0.2 ** (1 / 3))
    assert s["plan_vs_iql"]["ratio"] == pytest.approx(0.1 ** (1 / 3))
    assert s["uninformative"] == pytest.approx(1 / 3)
    oracle = (0.3 * 0.2 * 0.5) ** (1 / 3)
    assert s["rows"]["NDR-QL (oracle)"]["vs_iql"]["ratio"] == pytest.approx(oracle)
    assert s["share_geo"] == pytest.approx((1 - 0.1 ** (1 / 3)) / (1 - oracle))
    assert s["share_geo_raw"] == pytest.approx((1 - 0.2 ** (1 / 3)) / (1 - oracle))
    assert "share" not in s  # the pooled share against QL needs the QL row, not run here
    assert s["rows"]["NDR-QL (model)"]["vs_ql"] is None


def _judged(rec: dict, exact_ok: bool, model_ok: bool = True, exact_s: float = 0.005) -> dict:
    """``rec`` with the judge's verdicts as transfer now records them, and the exact source's seconds."""
    verdict = lambda ok: {"accepted": ok, "threshold": 0.9 if ok else None, "reason": None if ok else "no"}  # noqa: E731
    return {**rec, "verdicts": {"model": verdict(model_ok), "exact": verdict(exact_ok)},
            "seconds": {**rec["seconds"], "exact": exact_s}}


def _judged_three(n: int = 128, exact_b: bool = False, exact_s: tuple[float, ...] = (0.005,) * 3) -> list[dict]:
    """_three with verdicts: the exact source accepted on a1 and a2 (plan runs the oracle row's priors: 300 and
    400 steps against IQL-BFS's 1000 and 2000), on b1 as ``exact_b`` says (rejected: plan runs IQL-BFS, 800)."""
    a1, a2, b1 = _three(n)
    return [_judged(a1, True, exact_s=exact_s[0]), _judged(a2, True, exact_s=exact_s[1]),
            _judged(b1, exact_b, model_ok=False, exact_s=exact_s[2])]


def test_plan_row_follows_the_judges_verdicts():
    a1, a2, b1 = _judged_three()
    assert [tr.plan_row(r) for r in (a1, a2, b1)] == ["NDR-QL (oracle)", "NDR-QL (oracle)", "IQL (BFS distance)"]
    assert [tr.model_row(r) for r in (a1, b1)] == ["NDR-QL (model)", "IQL (BFS distance)"]
    old = _three()[2]  # a record written before the verdicts: the model row where informative, else IQL
    assert tr.plan_row(old) == "IQL" and tr.plan_row(_three()[0]) == "NDR-QL (model)"
    s = summarize([a1, a2, b1])
    assert s["plan_vs_bfs"]["ratio"] == pytest.approx((0.3 * 0.2 * 1.0) ** (1 / 3))
    assert s["exact_rejected"] == pytest.approx(1 / 3)


def test_the_floors_block_says_met_or_missed_with_the_number():
    text = render_large(_judged_three(), (128,))
    assert "**Floors at grid 128** (issue 53: NDR-QL against the exact distance, and its time): 3 of 3 met." in text
    assert ("- no family where NDR-QL (as plan runs it) needs more than 1.02x IQL-BFS's steps (geometric mean): "
            "highest maze 1.000: met") in text
    assert ("- prediction and priors at most 2 s on every map: median 0.005 s, 95th percentile 0.005 s, "
            "max 0.005 s: met") in text
    # work: the exact source's 0.005 s plus the oracle row's 0.01 s against IQL-BFS's 0.01 s; IQL-BFS itself on b1
    assert "- NDR-QL's in-process work at most 3x IQL-BFS's (median over maps): 1.50x: met" in text
    # the exact source accepted on the maze as well, its row there taking 2x IQL-BFS's steps, and slow on one map
    recs = _judged_three(exact_b=True, exact_s=(0.5, 0.5, 2.5))
    recs[2]["runs"]["NDR-QL (oracle)"] = _row([1600, 1600])
    worse = render_large(recs, (128,))
    assert "0 of 3 met." in worse
    assert "IQL-BFS's steps (geometric mean): maze 2.000: missed" in worse
    assert "median 0.500 s, 95th percentile 2.300 s, max 2.500 s: missed" in worse
    assert "(median over maps): 51.00x: missed" in worse
    fl = floors(_judged_three(256), 256)
    assert [f.met for f in fl] == [True, True, True]
    assert floors(_three(), 128)[0].line().endswith("highest maze 1.000: met")  # older records: no work floor
    assert len(floors(_three(), 128)) == 2
    assert "| 128 | 0.300 / " in text  # the stage table: the model forward's median first


def test_a_capped_run_counts_as_not_converged_and_wins_nothing():
    recs = _three(ndr_converged=[False, True])
    o = summarize(recs)["rows"]["NDR-QL (model)"]["against_iql"]
    # a1 and a2 would be clear wins; capped on one seed each while IQL converged: losses; b1 a loss anyway
    assert (o["wins"], o["ties"], o["losses"]) == (0, 0, 3)
    assert capped_runs(recs) == 3 and capped_runs(recs, "IQL") == 0
    assert summarize(recs)["rows"]["NDR-QL (model)"]["path"]["not_converged"] == 3


def test_rows_default_to_every_row_up_to_100_cells_and_drop_the_ql_rows_above():
    assert default_rows(50) == default_rows(100) == ROWS
    assert default_rows(128) == default_rows(256) == ("IQL", "IQL (BFS distance)", "NDR-QL (model)", "NDR-QL (oracle)")
    assert not_run_note(100, ROWS) == ""
    assert not_run_note(256, default_rows(256)) == \
        "Rows not run at grid 256: QL, QL (tuned) (QL rows not run above 100 cells: ~10^7 steps per run)."
    assert parse_rows(None) is None and parse_rows("all") == ROWS
    assert parse_rows("NDR-QL (model), IQL") == ("IQL", "NDR-QL (model)")
    assert not_run_note(50, ("IQL", "NDR-QL (model)")).endswith("(left out by --rows).")
    with pytest.raises(NdrqlError, match="unknown row 'QL tuned'"):
        parse_rows("IQL,NDR-QL (model),QL tuned")
    with pytest.raises(NdrqlError, match="must include IQL and NDR-QL"):
        parse_rows("QL,IQL")
    text = render_tables(_three(256), (256,))
    assert "Rows not run at grid 256: QL, QL (tuned) (QL rows not run above 100 cells" in text
    assert "| QL |" not in text and "| IQL |" in text


def test_the_size_ladder_is_unchanged_up_to_100_cells_and_reaches_512_above():
    assert larger_sizes(50) == (64, 80, 100) and larger_sizes(64) == (80, 100, 128)
    assert larger_sizes(80) == (100, 128) and larger_sizes(100) == (128,)
    assert larger_sizes(128) == (160, 200, 256) and larger_sizes(256) == (320, 400, 512)
    assert ladder_top(100) == 128 and ladder_top(128) == 256 and ladder_top(400) == 512


def test_stage_medians_skip_what_was_not_timed():
    recs = _three()
    del recs[0]["seconds"]
    m = stage_medians(recs)
    assert m["prediction"] == 0.3 and m["NDR-QL (model)"] == 0.01 and "QL" not in m
    assert set(m) == {"prediction", "astar", "bfs", *default_rows(128)}


TINY = {"sets": {"dev-tiny": {"role": "development", "families": ["blocks", "maze"], "sizes": [96], "count": 2,
                              "seed": 900_901}}}


@pytest.mark.slow
def test_the_rows_run_and_the_stage_times_are_recorded(monkeypatch, tmp_path, model_weights):
    from ndrql.experiments.transfer import transfer

    monkeypatch.setenv("NDRQL_CACHE", str(tmp_path / "cache"))
    sets = parse_registry(TINY)
    monkeypatch.setattr(eval_sets, "registry", lambda: sets)
    monkeypatch.setattr(tr, "QL_ROW_LIMIT", 20)  # grid 32 stands for a large grid: QL rows left out by default
    path = transfer(tmp_path / "out", weights=str(model_weights), set_name="dev-tiny", grids=(32,), seeds=1,
                    workers=1, executor="serial", progress=False, log=lambda m: None)
    text = path.read_text()
    assert "Rows not run at grid 32: QL, QL (tuned) (QL rows not run above 20 cells: ~10^7 steps per run)." in text
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["rows"] == {"32": list(default_rows(128))} and set(summary["constants"]["32"]) == set(default_rows(128))
    planned = [r for r in summary["records"] if not r["skipped"]]
    assert planned
    for r in planned:
        assert set(r["runs"]) == set(default_rows(128)) and set(r["seconds"]) == {"prediction", "exact", "astar", "bfs"}
        assert set(r["verdicts"]) == {"model", "exact"}
        assert all(x["max_episodes"] == 20000 and x["max_steps"] == 4 * r["size"] ** 2 and x["seconds"] > 0
                   for x in r["runs"].values())
    assert "**Time per stage**" in text and "| run: IQL |" in text


class _SpyModel:
    """Stands for a grid-mode predictor: records the side of every input it is asked to predict on."""

    encoding = "point"

    def __init__(self, view: str, companion: "_SpyModel | None" = None):
        from ndrql.dataset.views import GridView

        self.view, self.companion, self.sides = GridView.parse(view), companion, []

    def serving(self, n: int) -> "_SpyModel":
        return self.companion if self.companion is not None and self.view.factor(n) > 1 else self

    def predict_batch(self, x):
        import numpy as np

        self.sides.append(x.shape[-1])
        return np.ones((1,) + x.shape[-2:]), np.ones((1,) + x.shape[-2:])


@pytest.mark.parametrize("n,own,base_side,companion_side", [(100, False, 400, None), (160, False, None, 480),
                                                        (160, True, 320, None)])
def test_region_f1_above_the_views_limit_is_the_companions_under_its_own_view(n, own, base_side, companion_side):
    """The report's region F1 names the prediction plan used: above 128 cells the companion's on the grid
    drawn at its view's 3 px per cell (480 px at 160 cells), not the base model's native 640 px input; where
    the base's second opinion served (``own``), the base's under its own view (80 merged cells, 320 px)."""
    import numpy as np

    from ndrql.experiments.ceiling import grid_case
    from ndrql.experiments.transfer import _f1

    companion = _SpyModel("cap:512")
    base = _SpyModel("coarse:128", companion)
    obstacles = np.zeros((640, 640), bool)
    case = grid_case("k", "open", obstacles, (20, 20), (600, 610), n)
    region_f1, guide_f1 = _f1(base, "grid", case, None, own=own)
    assert base.sides == ([base_side] if base_side else []) and companion.sides == ([companion_side] if companion_side else [])
    assert 0 < region_f1 < 1 and 0 < guide_f1 < 1  # an all-ones prediction: recall 1, precision the label's share
