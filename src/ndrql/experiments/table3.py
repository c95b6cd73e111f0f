"""Table 3 of the paper: QL, O-QL, IQL and NDR-QL on the 8 fixed test maps, many seeds.

The paper reports one run per map; here every cell is the mean (and median, 95% CI) over seeds,
beside the paper's number, and the improvement over QL is pooled over maps as the paper computes
it (:mod:`ndrql.experiments.fixed_maps`). With the model's priors, NDR-QL also runs with the oracle's
(row ``NDR-QL (oracle priors)``, same maps and seeds) and the table gives the model's share of the
oracle's reduction; with ``opts.prior_from == "oracle"`` the NDR-QL row itself has the oracle's priors.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from ndrql.experiments.fixed_maps import fixed_map_table
from ndrql.experiments.paper import paper_table
from ndrql.experiments.planning_runs import SweepOptions
from ndrql.planning.methods import get_method

#: Table 3's rows (the registry's methods), in the paper's order.
TABLE3_METHODS = ("QL", "O-QL", "IQL", "NDR-QL")


def table3(opts: SweepOptions, out_dir: str | Path, log: Callable[[str], None] = print) -> Path:
    """Table 3: QL, O-QL, IQL, NDR-QL on the 8 fixed maps."""
    paper = paper_table("table3")
    oracle_rows = [get_method("NDR-QL")] if opts.prior_from == "model" else []
    return fixed_map_table("table3", [get_method(m) for m in TABLE3_METHODS], 8, opts, out_dir,
                           paper["steps"], paper["paths"], paper["improvement"], log, oracle_rows)
