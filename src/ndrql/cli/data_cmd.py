"""``ndrql data``: generate training/evaluation maps with labels, and look at them.

Example::

    ndrql data generate --family maze,rooms,office --count 2000 --size 201,401 --seed 1 --out ~/.cache/ndrql/gen/a
    ndrql data generate ... --out ~/.cache/ndrql/gen/a     # the same command again resumes an interrupted run
    ndrql data show ~/.cache/ndrql/gen/a --png sheet.png --count 24 --mode grid --grid 50

``generate`` writes samples (map, start, goal, near-optimal path, family) in shards under ``--out``:
deterministic per seed (sample i depends only on the seed and i), resumable, any number of
``--workers``. ``show`` draws a contact sheet of a set: the model's input with region and
guideline labels, as the chosen input mode renders them. ``ndrql train --sources`` reads the sets.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ndrql.cli.options import add_command
from ndrql.dataset.render import render
from ndrql.errors import NdrqlError
from ndrql.io import save_figure
from ndrql.maps.grid import MODEL_SIDE, PLANNING_SIZE
from ndrql.viz.sheet import contact_sheet
from ndrql.viz.style import DEFAULT_DPI


def _int_list(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from None


def register(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "data", help="generate map sets with labels (map engine) and draw them", description=__doc__)
    dsub = p.add_subparsers(dest="data_command", metavar="ACTION")
    g = dsub.add_parser("generate", help="write a generated set (resumable, deterministic per seed)")
    g.add_argument("--family", required=True, help="families, comma-separated (ndrql.synth.families), or 'all'")
    g.add_argument("--count", type=int, required=True, help="number of samples")
    g.add_argument("--size", type=_int_list, default=(MODEL_SIDE,),
                   help=f"map sides in px, comma-separated; each sample draws one (default: {MODEL_SIDE})")
    g.add_argument("--seed", type=int, default=0, help="seed of the set (default: 0)")
    g.add_argument("--masks", default="", help="also draw a belief of each map for the model for belief maps "
                   "(ndrql.synth.belief_sets), e.g. blobs:0.1-0.5,sensed,outdated,none:0.2 (none: the share of maps "
                   "with nothing hidden, default 0.2); default: no beliefs")
    g.add_argument("--mask-seed", type=int, default=0, help="seed of the beliefs with --masks (a training seed, "
                   "0..899999; default: 0)")
    g.add_argument("--out", type=Path, required=True, help="output directory (new, empty, or a partial run of the same set)")
    g.add_argument("--workers", type=int, default=1, help="processes (default: 1; results do not depend on it)")
    g.add_argument("--no-progress", action="store_true", help="no progress bar")
    g.set_defaults(func=run_generate)
    s = dsub.add_parser("show", help="draw a contact sheet of a generated set")
    s.add_argument("set", type=Path, help="a directory written by `ndrql data generate`")
    s.add_argument("--png", type=Path, required=True, help="output PNG")
    s.add_argument("--count", type=int, default=16, help="samples drawn, spread over the set (default: 16)")
    s.add_argument("--mode", default="map", help="input mode to render: map or grid (default: map)")
    s.add_argument("--grid", type=int, default=PLANNING_SIZE, help=f"planning grid size to render for (default: {PLANNING_SIZE})")
    s.set_defaults(func=run_show)
    p.set_defaults(func=lambda args: (p.print_help(), 0)[1])


def run_generate(args: argparse.Namespace) -> int:
    from ndrql.dataset.generated import generate_set  # lazy: loads scipy
    from ndrql.synth.families import family_names  # lazy: loads scipy
    from ndrql.synth.generate import SetSpec  # lazy: loads scipy

    families = family_names() if args.family.strip() == "all" else tuple(f.strip() for f in args.family.split(",") if f.strip())
    if not 1 <= args.workers <= 256:
        raise NdrqlError(f"--workers must be 1..256, got {args.workers}")
    if args.mask_seed and not args.masks:
        raise NdrqlError("--mask-seed is the seed of the beliefs: give --masks too")
    spec = SetSpec(families, tuple(args.size), args.count, args.seed, args.masks, args.mask_seed)
    root = generate_set(args.out, spec, workers=args.workers, progress=not args.no_progress, log=print)
    beliefs = f", beliefs {spec.masks} (mask seed {spec.mask_seed})" if spec.masks else ""
    print(f"wrote {spec.count} samples of {', '.join(spec.families)} ({', '.join(map(str, spec.sizes))} px, seed "
          f"{spec.seed}{beliefs}) to {root}")
    return 0


def run_show(args: argparse.Namespace) -> int:
    import numpy as np

    from ndrql.dataset.generated import GeneratedSet  # lazy: loads scipy

    if not 1 <= args.count <= 400:
        raise NdrqlError(f"--count must be 1..400, got {args.count}")
    gs = GeneratedSet.load(args.set)
    ids = np.unique(np.linspace(0, len(gs) - 1, min(args.count, len(gs))).astype(int))
    items = []
    for i in ids:
        raw = gs.raw(int(i))
        r = render(args.mode, raw.obstacles, raw.start, raw.goal, raw.waypoints, args.grid)
        items.append((f"{i} {raw.family} {raw.obstacles.shape[0]}px", r))
    save_figure(contact_sheet(items, title=f"{args.set.name}: {args.mode} mode, grid {args.grid}"), args.png, dpi=DEFAULT_DPI)
    print(f"wrote {args.png}")
    return 0
