"""Which entry of the shipped ``general`` preset serves which planning grid (studies/large_view/history.md,
a search of the planners' constants at 128 cells, and exploration where IQL is already at its minimum).

- Grids up to 113 cells (50, 100 and the paper's 50-cell grids) keep the constants they were reported with.
- Grids of 114-181 cells take the grid-128 entry: NDR-QL's searched constants and IQL's grid-100 constants, each
  with the epsilon of the sweep of 2026-11-27 (the same six values for both methods).
- Grids above 181 cells take the grid-256 entry, which keeps what they were judged with on ``sealed-large-256-k``:
  NDR-QL's grid-128 constants before the sweep, IQL's grid-100 constants.
- QL and O-QL keep grid 100's above 70 cells.
"""

from __future__ import annotations

import dataclasses

import pytest

from ndrql.planning.preset import load_preset


@pytest.fixture(scope="module")
def general():
    return load_preset("general")


def _without_epsilon(setting):
    return dataclasses.replace(setting, ql=dataclasses.replace(setting.ql, epsilon=0.0))


def test_each_grid_takes_its_entry(general):
    assert sorted(general.grids) == [50, 100, 128, 256]
    assert set(general.grids[128]) == set(general.grids[256]) == {"IQL", "NDR-QL"}
    for method in ("IQL", "NDR-QL"):
        at = {n: general.setting(method, n) for n in range(20, 513)}
        assert all(at[n] == general.grids[50][method] for n in range(20, 71))
        assert all(at[n] == general.grids[100][method] for n in range(71, 114))
        assert all(at[n] == general.grids[128][method] for n in range(114, 182))
        assert all(at[n] == general.grids[256][method] for n in range(182, 513))


def test_the_sweep_changed_only_epsilon_at_114_to_181_cells(general):
    """The grid-128 entry is the grid-256 entry (what 256 cells were judged with) with another epsilon; IQL's
    grid-256 entry is grid 100's."""
    assert general.grids[256]["IQL"] == general.grids[100]["IQL"]
    assert general.grids[256]["NDR-QL"] != general.grids[100]["NDR-QL"]
    for method, eps in (("IQL", 0.001), ("NDR-QL", 0.0006)):
        assert general.grids[128][method].ql.epsilon == eps
        assert _without_epsilon(general.grids[128][method]) == _without_epsilon(general.grids[256][method])
    sweep = general.meta["grids"]["128"]["epsilon_sweep"]
    assert sweep["chosen"] == {"IQL": 0.001, "NDR-QL": 0.0006}
    for method in ("IQL", "NDR-QL"):  # the rule's adoption check: fewer steps on the seeds the choice did not see
        check = sweep["adoption_check"][method]
        assert check["chosen"] < check["shipped"] and check["worst_path_chosen"] <= check["worst_path_shipped"]
    assert general.meta["grids"]["256"]["search"]["grid"] == 128


@pytest.mark.parametrize("method", ["QL", "O-QL"])
def test_the_other_methods_keep_grid_100_above_70_cells(general, method):
    assert all(general.setting(method, n) == general.grids[100][method] for n in (71, 100, 113, 114, 128, 256, 512))


def test_iql_search_at_128_cells_is_recorded_as_not_shipped(general):
    meta = general.meta["grids"]["128"]
    assert meta["search"]["eval_set"] == "large-dev2-128" and set(meta["studies"]) == {"NDR-QL"}
    assert meta["validation_check"]["NDR-QL"]["tuned_wins"]
    iql = meta["bounded_search_not_shipped"]["IQL"]
    assert iql["search"]["eval_set"] == "large-dev2-128" and iql["validation_check"]["tuned"]["worst_map"] <= 2.0
    assert "2.27x" in iql["why"]
