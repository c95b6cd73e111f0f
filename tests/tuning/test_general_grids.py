"""Which entry of the shipped ``general`` preset serves which planning grid (docs/large-maps.md, a search of the
planners' constants at 128 cells): NDR-QL's grid-128 entry serves every grid above 113 cells and no grid up
to 113, so grids 50 and 100 and the paper's 50-cell grids keep the constants they were reported with; IQL
(and QL, O-QL) keep grid 100's above 70 cells, since IQL's bounded search at 128 cells was not shipped."""

from __future__ import annotations

import pytest

from ndrql.planning.preset import load_preset


@pytest.fixture(scope="module")
def general():
    return load_preset("general")


def test_ndr_ql_takes_the_grid_128_entry_above_113_cells_only(general):
    at = {n: general.setting("NDR-QL", n) for n in range(20, 513)}
    assert sorted(general.grids) == [50, 100, 128] and set(general.grids[128]) == {"NDR-QL"}
    assert all(at[n] == general.grids[50]["NDR-QL"] for n in range(20, 71))
    assert all(at[n] == general.grids[100]["NDR-QL"] for n in range(71, 114))
    assert all(at[n] == general.grids[128]["NDR-QL"] for n in range(114, 513))
    assert general.grids[128]["NDR-QL"] != general.grids[100]["NDR-QL"]


@pytest.mark.parametrize("method", ["QL", "O-QL", "IQL"])
def test_the_other_methods_keep_grid_100_above_70_cells(general, method):
    assert all(general.setting(method, n) == general.grids[100][method] for n in (71, 100, 113, 114, 128, 256, 512))


def test_iql_search_at_128_cells_is_recorded_as_not_shipped(general):
    meta = general.meta["grids"]["128"]
    assert meta["search"]["eval_set"] == "large-dev2-128" and set(meta["studies"]) == {"NDR-QL"}
    assert meta["validation_check"]["NDR-QL"]["tuned_wins"]
    iql = meta["bounded_search_not_shipped"]["IQL"]
    assert iql["search"]["eval_set"] == "large-dev2-128" and iql["validation_check"]["tuned"]["worst_map"] <= 2.0
    assert "2.27x" in iql["why"]
