"""``ndrql tune --export-preset ... --keep-from PRESET``: re-searched methods replace theirs, the rest is kept
(other grids whole; a new grid is added)."""

from __future__ import annotations

from dataclasses import replace

import pytest

from ndrql.cli.tune_cmd import kept_entries
from ndrql.planning.config import QLConfig
from ndrql.planning.preset import MethodSetting, load_preset


def test_kept_entries_replace_only_the_searched_methods():
    base = load_preset("general")
    new = {n: {"NDR-QL": MethodSetting(QLConfig(alpha=0.25 + n / 1000))} for n in (50, 100)}
    metas = {str(n): {"studies": {"NDR-QL": {"study": f"s{n}"}}, "validation_check": {"NDR-QL": {"tuned_wins": True}},
                      "kept_spec": [], "search": {"weights_sha256_16": "new"}} for n in (50, 100)}
    entries, meta = kept_entries(base, new, metas)
    for n in (50, 100):
        assert entries[n]["NDR-QL"].ql.alpha == pytest.approx(0.25 + n / 1000)
        assert all(entries[n][m] == base.grids[n][m] for m in ("QL", "O-QL", "IQL"))
        m = meta[str(n)]
        assert m["studies"]["NDR-QL"] == {"study": f"s{n}"}
        assert m["studies"]["IQL"] == base.meta["grids"][str(n)]["studies"]["IQL"]
        assert m["search_by_method"]["NDR-QL"] == {"weights_sha256_16": "new"}
        assert m["kept_spec"] == [k for k in base.meta["grids"][str(n)]["kept_spec"] if k != "NDR-QL"]


def test_kept_entries_keep_the_grids_not_searched_and_add_a_new_one():
    base = load_preset("general")
    assert 512 not in base.grids
    new = {512: {"NDR-QL": MethodSetting(QLConfig(alpha=0.3)), "IQL": MethodSetting(QLConfig(alpha=0.4))}}
    metas = {"512": {"studies": {m: {"study": m} for m in new[512]}, "validation_check": {}, "kept_spec": ["IQL"],
                     "search": {"weights_sha256_16": "new"}, "check_seeds": [2, 3]}}
    entries, meta = kept_entries(base, new, metas)
    assert sorted(entries) == sorted([*base.grids, 512]) and list(meta) == [str(n) for n in sorted(entries)]
    assert all(entries[n] == dict(base.grids[n]) for n in base.grids)
    assert meta["100"] == base.meta["grids"]["100"]
    assert entries[512] == new[512] and meta["512"]["kept_spec"] == ["IQL"]
    assert meta["512"]["search"] == {"weights_sha256_16": "new"} and meta["512"]["check_seeds"] == [2, 3]
    assert meta["512"]["search_by_method"] == {"NDR-QL": {"weights_sha256_16": "new"}, "IQL": {"weights_sha256_16": "new"}}
    preset = replace(base, grids=entries)
    assert preset.setting("NDR-QL", 400).ql.alpha == 0.3  # 400 cells: nearest to 512 on a log scale
    assert preset.setting("NDR-QL", 300) == base.setting("NDR-QL", 300)  # nearer a kept entry than 512
    assert preset.setting("QL", 512) == base.setting("QL", 100)  # not searched at 512: the nearest entry listing it
