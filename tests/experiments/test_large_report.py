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
from ndrql.experiments.transfer_floors import floors, render_large, stage_medians
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


def test_the_floors_block_says_met_or_missed_with_the_number():
    text = render_large(_three(), (128,))
    assert "**Floors at grid 128** (docs/large-maps.md, 'Floors for the next model'): 3 of 4 met." in text
    assert "- NDR-QL / IQL steps, geometric mean with plan's fallback, at most 0.6: 0.46 (0.58 without the fallback): met" in text
    assert "- prediction uninformative on at most 10% of maps: 33% of 3: missed" in text
    assert "- no family where NDR-QL (with the fallback) is slower than IQL in the geometric mean: none slower: met" in text
    share = 100 * (1 - 0.1 ** (1 / 3)) / (1 - 0.03 ** (1 / 3))
    assert f"- share of the oracle's gain over IQL in geometric means at least 75%: {share:.0f}%: met" in text
    assert "prediction at" not in text  # judged at 256 cells only
    # maze informative now (threshold 0.3): its 2.0 counts, the family is slower than IQL
    fl = {f.name.split(",")[0]: f for f in floors(_three(thd_b=0.3), 128)}
    assert fl["no family where NDR-QL (with the fallback) is slower than IQL in the geometric mean"].line().endswith(
        "slower: maze 2.00: missed")
    at256 = render_large(_three(256, predict_s=0.7), (256,))
    assert "- prediction at 256 cells at most 0.5 s (median): 0.70 s: missed" in at256 and "of 5 met" in at256
    assert "| 256 | 0.700 | 0.010 | 0.020 |" in at256


def test_a_capped_run_counts_as_not_converged_and_wins_nothing():
    recs = _three(ndr_converged=[False, True])
    o = summarize(recs)["rows"]["NDR-QL (model)"]["against_iql"]
    # a1 and a2 would be clear wins; capped on one seed each while IQL converged: losses; b1 a loss anyway
    assert (o["wins"], o["ties"], o["losses"]) == (0, 0, 3)
    line = floors(recs, 128)[0].line()
    assert line.endswith("; 3 runs hit their cap: missed")
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
        assert set(r["runs"]) == set(default_rows(128)) and set(r["seconds"]) == {"prediction", "astar", "bfs"}
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
