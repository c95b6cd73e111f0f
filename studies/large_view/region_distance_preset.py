"""The candidate preset of docs/large-maps.md#distance-through-the-region: the shipped ``general`` preset with
``region_distance`` 1 in NDR-QL's entries for the given grids (default 128: every grid above 113 cells), named
``general-rd``; checked by loading it back. Its default is what the development reports judged; since
2026-11-27 the shipped preset has it at grid 128 too, so today only ``--grids 50,100`` changes anything::

    PYTHONPATH=src python studies/large_view/region_distance_preset.py --out general-rd.json [--grids 128]
    ndrql reproduce transfer --eval-set large-dev2-256 --grids 256 --weights general --preset general-rd.json ...
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ndrql.planning.preset import load_preset

SHIPPED = Path(__file__).resolve().parents[2] / "src" / "ndrql" / "planning" / "presets" / "general.json"


def candidate(grids: list[str]) -> dict:
    """The shipped preset's JSON with NDR-QL's ``region_distance`` 1 on ``grids`` (each must have an NDR-QL entry)."""
    data = json.loads(SHIPPED.read_text())
    data["name"] = "general-rd"
    for g in grids:
        entry = data["grids"].get(g, {}).get("NDR-QL")
        if entry is None:
            raise SystemExit(f"the general preset has no NDR-QL entry at grid {g} (it has: {', '.join(data['grids'])})")
        entry["priors"]["region_distance"] = 1
    return data


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
