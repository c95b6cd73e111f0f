"""The candidate preset of history.md#distance-through-the-region: the shipped ``general`` preset with
``region_distance`` 1 in NDR-QL's entries for the given grids (default 128: every grid above 113 cells), named
``general-rd``; checked by loading it back. Its default is what the development reports judged; since
2026-11-27 the shipped preset has it at every grid, so it changes nothing today: it is kept for the commands
quoted with it, a thin use of ``preset_variant.py`` beside it::

    PYTHONPATH=src python studies/large_view/region_distance_preset.py --out general-rd.json [--grids 128]
    ndrql reproduce transfer --eval-set large-dev2-256 --grids 256 --weights general --preset general-rd.json ...
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ndrql.planning.preset import load_preset

sys.path.insert(0, str(Path(__file__).resolve().parent))
from preset_variant import variant  # noqa: E402  (the script beside this one)


def candidate(grids: list[str]) -> dict:
    """The shipped preset's JSON with NDR-QL's ``region_distance`` 1 on ``grids`` (each must have an NDR-QL entry)."""
    return variant(grids, {"region_distance": 1}, name="general-rd")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--grids", default="128", help="comma-separated grid entries to switch (default 128)")
    a = ap.parse_args(argv)
    grids = [g.strip() for g in a.grids.split(",") if g.strip()]
    a.out.write_text(json.dumps(candidate(grids), indent=1) + "\n")
    p = load_preset(a.out)
    on = [g for g in grids if p.configs("NDR-QL", grid=int(g))[1].region_distance == 1]
    print(f"wrote {a.out}: NDR-QL counts Eq. 6's distance through the region on grid entries {', '.join(on)}")


if __name__ == "__main__":
    main()
