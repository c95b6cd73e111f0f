"""studies/win_share_search.py's ``--priors``: the probes' preset with prior constants set on every row."""

from __future__ import annotations

import importlib

import pytest


@pytest.fixture(scope="module")
def probes():
    return importlib.import_module("win_share_search")


def _args(probes, *argv: str):
    return probes.probe_parser("A probe.", symmetries=4).parse_args(list(argv))


def test_priors_set_on_every_row(probes):
    shipped = probes.probe_preset(_args(probes))
    assert shipped.configs("NDR-QL", grid=50)[1].guideline_ties == 0.3
    before = probes.probe_preset(_args(probes, "--priors", "guideline_ties=0, region_dilation=0"))
    for grid in (50, 100):
        _, p = before.configs("NDR-QL", grid=grid)
        assert (p.guideline_ties, p.region_dilation) == (0.0, 0)
        assert p.r_max == shipped.configs("NDR-QL", grid=grid)[1].r_max  # the rest stays the preset's


@pytest.mark.parametrize("value, match", [("guideline_ties", "K=V"), ("nope=1", "nope"),
                                          ("guideline_ties=2", "guideline_ties")])
def test_bad_priors_are_one_clear_line(probes, value, match):
    with pytest.raises(SystemExit, match=match):
        probes.probe_preset(_args(probes, "--priors", value))
