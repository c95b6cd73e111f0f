"""Table 2 of the paper: the ablation of NDR-QL's priors on MAP-1 .. MAP-5, many seeds.

Rows combine the continuous rewards (D-C: Eq. 2, N-C: Eq. 3, both: Eq. 4) and the Q-table
initialisations (D-Q: Eq. 5, N-Q: Eq. 6's mask term alone, D-Q + N-Q: Eq. 6 as a whole); NDR-QL
has all four. Every row runs at the preset's NDR-QL constants (:mod:`ndrql.experiments.presets`),
so only the priors differ.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from ndrql.experiments.fixed_maps import fixed_map_table
from ndrql.experiments.paper import paper_table
from ndrql.experiments.planning_runs import SweepOptions
from ndrql.planning.methods import Method

#: Table 2's rows in the paper's order. ``N-Q`` alone is Eq. 6's mask term only; ``D-Q + N-Q`` is
#: Eq. 6 as a whole, which is what the registry's ``N-Q`` method runs (it contains the D-QI term).
TABLE2_ROWS = (
    Method("D-C", d_crf=True),
    Method("N-C", n_crf=True),
    Method("D-C+N-C", d_crf=True, n_crf=True),
    Method("D-Q", d_qi=True),
    Method("N-Q", n_qi=True, qi_mask_only=True),
    Method("D-Q+N-Q", d_qi=True, n_qi=True),
    Method("NDR-QL", d_crf=True, n_crf=True, d_qi=True, n_qi=True),
)


def table2(opts: SweepOptions, out_dir: str | Path, log: Callable[[str], None] = print) -> Path:
    """Table 2: the D-C / N-C / D-Q / N-Q ablation on MAP-1..MAP-5."""
    return fixed_map_table("table2", TABLE2_ROWS, 5, opts, out_dir, paper_table("table2")["steps"], None, None, log)
