"""The transfer figure: one model/oracle column pair per family, drawn on a bare Figure."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.figure import Figure

from ndrql.viz.transfer import PredictionPanel, transfer_figure


def _panel(family: str) -> PredictionPanel:
    blocked = np.zeros((8, 8), bool)
    blocked[2:6, 4] = True
    region = np.zeros((8, 8))
    region[1, :] = 1.0
    return PredictionPanel(family, blocked, (1, 1), (6, 6), (region, region * 0.5), (region.T, region.T), "(8x8)")


def test_pairs_of_rows_per_family_on_a_bare_figure():
    fig = Figure()
    out = transfer_figure([_panel(f) for f in ("a", "b", "c")], "general", fig=fig, columns=2)
    assert out is fig
    axes = fig.get_axes()
    assert len(axes) == 2 * 2 * 2  # 2 row pairs x 2 columns
    visible = [ax for ax in axes if ax.axison]
    assert len(visible) == 6  # 3 families x (model, oracle)
    titles = [ax.get_title() for ax in visible]
    assert titles[:2] == ["a (8x8)\ngeneral", "b (8x8)\ngeneral"] and titles.count("oracle") == 3
    # each visible panel carries the map and both overlays (region, guideline) as images
    assert all(len(ax.get_images()) == 3 for ax in visible)


def test_no_panels_is_an_error():
    with pytest.raises(ValueError, match="no panels"):
        transfer_figure([], "general", fig=Figure())
