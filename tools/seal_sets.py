"""Record the digests of every registered evaluation set, and of the training sets the scripts draw.

Writes ``src/ndrql/experiments/set_digests.json``: for each set of ``transfer_sets.json`` its spec and the
SHA-256 (16 hex digits) of every map and every problem (map, start, goal), recorded when the set is first
drawn; ``ndrql reproduce release`` refuses a sealed set whose maps no longer match. An entry that exists
is never changed (a set is drawn once): a set missing from the file is added, one whose spec changed is
an error. ``training``: the first ``--training-count`` samples of each training set of the scripts
(``tools/train_general.sh``: the shipped model's twelve families, 201/401/801 px, seed 1), for the duplicate test
(tests/experiments/test_sealed_sets.py).

    python tools/seal_sets.py                       # add what is missing
    python tools/seal_sets.py --check               # regenerate every set and compare (no write)
    python tools/seal_sets.py --only partial-dev,sealed-partial   # just these sets (no training sets)
"""

from __future__ import annotations

import argparse
import json
import os
import sys

from ndrql.dataset.generated import GeneratedSet, build_shard, check_purpose
from ndrql.experiments.eval_sets import digests_path, eval_set, registry, set_record
from ndrql.io import write_json
from ndrql.synth.families import family_names, shipped_families
from ndrql.synth.generate import SetSpec

#: The families the third companion drew more of (``ndrql data generate --family <these> --seed 7``), in that order.
HARD_FAMILIES = ("city", "narrow_passage", "maze", "scatter", "corridor_maze", "floor", "dungeon", "ros_scan")
#: The families the fourth companion drew more of (``--seed 8``): where the third broke or lost at 256 cells.
WEAK_FAMILIES = ("maze", "corridor_maze", "floor", "warehouse", "scatter")
#: The training sets the scripts and docs generate: label -> (seed, sizes, families; None = the shipped model's
#: twelve). tools/train_general.sh: SEED=1, 201/401/801 px; the large-grid companion (studies/large_view/history.md):
#: ``--family all`` at seed 4 (201-1,024 px) and seed 6 (512/1,024 px), :data:`HARD_FAMILIES` at seed 7,
#: :data:`WEAK_FAMILIES` at seed 8, ``--family all`` at seed 9 (512/1,024 px); the belief model's second set
#: (``SEED=2 MASK_SEED=55 tools/train_belief.sh data``: the twelve, 201/401/801 px, seed 2) and its third (seed 3).
TRAINING_SETS = {"train_general (seed 1)": (1, (201, 401, 801), None),
                 "train large (seed 4)": (4, (201, 401, 512, 801, 1024), "all"),
                 "train large (seed 6)": (6, (512, 1024), "all"),
                 "train large, hard families (seed 7)": (7, (512, 1024), HARD_FAMILIES),
                 "train large, weak families (seed 8)": (8, (512, 1024), WEAK_FAMILIES),
                 "train large (seed 9)": (9, (512, 1024), "all"),
                 "train belief, second set (seed 2)": (2, (201, 401, 801), None),
                 "train belief, third set (seed 3)": (3, (201, 401, 801), None)}


def training_record(seed: int, sizes: tuple[int, ...], count: int, families: str | tuple[str, ...] | None = None) -> dict:
    """The digests of the first ``count`` samples of a training set (sample ``i`` depends only on seed and ``i``);
    ``families`` ``"all"`` draws every registered family (``ndrql data generate --family all``), ``None`` the
    shipped model's twelve, a tuple those families in that order."""
    names = family_names() if families == "all" else shipped_families() if families is None else tuple(families)
    spec = SetSpec(names, sizes, count, seed)
    check_purpose(seed, "training")
    arrays = build_shard(spec, 0, shard_size=count)
    gs = GeneratedSet(root=digests_path().parent, spec=spec, sizes=arrays["sizes"], points=arrays["points"],
                      families=arrays["families"], map_offsets=arrays["map_offsets"], maps=arrays["maps"],
                      wp_offsets=arrays["wp_offsets"], waypoints=arrays["waypoints"])
    return set_record(gs)


def _refuse(message: str) -> int:
    print(f"seal_sets: error: {message}", file=sys.stderr)
    return 2


def main(argv: list[str] | None = None) -> int:
    os.environ["NDRQL_WRITE_PACKAGE"] = "1"  # this tool refreshes files the package ships (ndrql.io.readset)
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--training-count", type=int, default=240, help="samples hashed per training set (default: 240)")
    ap.add_argument("--check", action="store_true", help="regenerate every recorded set and compare; write nothing")
    ap.add_argument("--only", default="", metavar="NAME[,NAME]",
                    help="record or check only these registered sets, and no training set (drawing every set takes hours)")
    args = ap.parse_args(argv)
    only = [n.strip() for n in args.only.split(",") if n.strip()]
    unknown = [n for n in only if n not in registry()]
    if unknown:
        return _refuse(f"--only: no registered set {unknown[0]!r}")
    path = digests_path()
    data = json.loads(path.read_text()) if path.exists() else {"sets": {}, "training": {}}
    changed = False
    for name, entry in registry().items():
        if only and name not in only:
            continue
        rec = set_record(eval_set(entry.spec, progress=False, release=True))
        old = data["sets"].get(name)
        if old is None:
            data["sets"][name] = {"role": entry.role, **rec}
            changed = True
            print(f"{name}: recorded {len(rec['maps'])} maps")
        elif {k: old[k] for k in rec} != rec:
            return _refuse(f"{name}: the maps differ from the recorded digests (a set is drawn once; register a new one)")
        else:
            print(f"{name}: matches its record")
    for label, (seed, sizes, families) in ({} if only else TRAINING_SETS).items():
        old = data["training"].get(label)
        count = len(old["maps"]) if old and args.check else args.training_count
        rec = training_record(seed, sizes, count, families)
        if old is None or (not args.check and len(old["maps"]) != count):
            data["training"][label] = rec
            changed = True
            print(f"{label}: recorded {count} samples")
        elif old != rec:
            return _refuse(f"{label}: the training maps differ from the recorded digests")
        else:
            print(f"{label}: matches its record")
    if changed and not args.check:
        write_json(path, data, indent=1)
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
