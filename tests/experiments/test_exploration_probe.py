"""tools/exploration_probe.py: wins, ties and clear losses counted by hand."""

from __future__ import annotations

import pytest

from helpers.tools import tool_module


@pytest.fixture(scope="module")
def probe():
    yield from tool_module("exploration_probe")


def test_outcome_counts_a_near_tie_on_either_side_once_and_a_clear_loss_apart(probe):
    iql = [1043.0, 1048.0, 1043.0, 2000.0, 1000.0]
    ndr = [1048.0, 1043.0, 1049.0, 1000.0, 1000.0]  # +0.48% (tie), -0.48% (won, tie), +0.58% (lost), won, equal
    won, tied, lost = probe.outcome(ndr, iql)
    assert (won, tied, lost) == (2, 3, 1)  # the exact tie counts as tied, not won
    assert probe.outcome(ndr, iql, tie=0.0) == (2, 1, 2)  # no tolerance: only the equal map ties
