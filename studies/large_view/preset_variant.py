"""A candidate preset for a development check: the shipped ``general`` preset with prior constants set in NDR-QL's
entries for the given grids, named ``general-variant``; checked by loading it back. The schedule's tail of
large_view/history.md#the-schedules-tail-rule-written-2026-11-27-before-its-runs::

    PYTHONPATH=src python studies/large_view/preset_variant.py --set thd_tail=1 --grids 50,100 --out general-tail.json
    ndrql reproduce transfer --eval-set select --grids 50,100 --weights general --preset general-tail.json ...

(``region_distance_preset.py`` is the same for ``region_distance``, kept for the commands quoted with it.)
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ndrql.planning.preset import PRESET_FIELDS, load_preset

SHIPPED = Path(__file__).resolve().parents[2] / "src" / "ndrql" / "planning" / "presets" / "general.json"


def variant(grids: list[str], values: dict[str, float], name: str = "general-variant") -> dict:
    """The shipped preset's JSON named ``name``, with ``values`` in NDR-QL's ``priors`` on ``grids`` (each must have
    an NDR-QL entry)."""
    bad = sorted(set(values) - set(PRESET_FIELDS["priors"]))
    if bad:
        raise SystemExit(f"not a prior constant a preset may set: {', '.join(bad)}")
    data = json.loads(SHIPPED.read_text())
    data["name"] = name
    for g in grids:
        entry = data["grids"].get(g, {}).get("NDR-QL")
        if entry is None:
            raise SystemExit(f"the general preset has no NDR-QL entry at grid {g} (it has: {', '.join(data['grids'])})")
        entry["priors"].update(values)
    return data


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--grids", default="50,100", help="comma-separated grid entries to change (default 50,100)")
    ap.add_argument("--set", required=True, action="append", metavar="NAME=VALUE", help="a prior constant (repeatable)")
    a = ap.parse_args(argv)
    grids = [g.strip() for g in a.grids.split(",") if g.strip()]
    values = {k: float(v) for k, v in (s.split("=", 1) for s in a.set)}
    a.out.write_text(json.dumps(variant(grids, values), indent=1) + "\n")
    p = load_preset(a.out)
    for g in grids:
        pc = p.configs("NDR-QL", grid=int(g))[1]
        print(f"{a.out}: NDR-QL at grid {g}: " + ", ".join(f"{k} {getattr(pc, k)}" for k in values))


if __name__ == "__main__":
    main()
