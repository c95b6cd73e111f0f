"""``ndrql reproduce transfer`` with another large-grid cut: ``plan`` calls a prediction on a grid above 128 cells
uninformative when no Eq. 7 threshold of at least the cut joins start and goal
(:data:`ndrql.pipeline.fallback.LARGE_MIN_THRESHOLD`, shipped 0.1); this runs the transfer report with the cut
given, inside ``plan`` (the second opinion and the relay follow the same verdict), for the rule of
large_view/history.md#low-thresholds-on-large-grids::

    PYTHONPATH=src python studies/large_view/cut_transfer.py --cut 0.02 -- --eval-set large-dev2-256 --grids 256 \\
        --weights general --preset general --seeds 3 --workers 2 --rows "IQL,NDR-QL (model)" --out DIR

Workers are forked (the platform default here), so they inherit the cut; on a platform without fork the script
refuses rather than run the workers on the shipped cut.
"""

from __future__ import annotations

import argparse
import multiprocessing
import sys

from ndrql.pipeline import fallback


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    ours, rest = (argv[:argv.index("--")], argv[argv.index("--") + 1:]) if "--" in argv else (argv, [])
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cut", type=float, required=True, help="the Eq. 7 threshold cut above 128 cells")
    a = ap.parse_args(ours)
    if not 0.0 <= a.cut < 1.0:
        ap.error(f"--cut must be in [0, 1), got {a.cut}")
    if multiprocessing.get_start_method(allow_none=False) != "fork":
        ap.error("workers must be forked to inherit the cut (this platform starts them otherwise)")
    fallback.LARGE_MIN_THRESHOLD = a.cut
    assert fallback.min_threshold(256) == a.cut
    from ndrql.cli import main as cli_main

    return cli_main(["reproduce", "transfer", *rest])


if __name__ == "__main__":
    sys.exit(main())
