"""``ndrql tune --export-preset ... --keep-from PRESET``: re-searched methods replace theirs, the rest is kept."""

from __future__ import annotations

import pytest

from ndrql.cli.tune_cmd import kept_entries
from ndrql.errors import NdrqlError
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
    with pytest.raises(NdrqlError, match="grids"):
        kept_entries(base, {50: new[50]}, {"50": metas["50"]})
