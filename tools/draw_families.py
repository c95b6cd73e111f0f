#!/usr/bin/env python3
"""Draw a contact sheet of the map engine's families: one row per family, a few seeds at two sizes.

    .venv/bin/python tools/draw_families.py                      # writes docs/synth-families.png
    .venv/bin/python tools/draw_families.py --large              # writes docs/synth-families-large.png
    .venv/bin/python tools/draw_families.py --families maze,office --sizes 201,1601 --out /tmp/sheet.png

Map k of a row is ``generate_map(family, np.random.default_rng(seed k), size, size)``: the same
picture every time.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ndrql.io import atomic_write
from ndrql.synth import family_names, generate_map
from ndrql.synth.families import LARGE_FAMILIES
from ndrql.viz.maps import new_figure

DOCS = Path(__file__).resolve().parents[1] / "docs"
#: The first figure's families (every family before the large ones) and the large families' figure.
FIRST = [f for f in family_names() if f not in LARGE_FAMILIES]


def draw_sheet(fig, families: list[str], sizes: list[int], seeds: list[int]) -> list:
    """One row per family, ``len(seeds)`` maps per size; returns the axes."""
    cols = len(sizes) * len(seeds)
    axes = []
    for i, name in enumerate(families):
        for j, size in enumerate(sizes):
            for k, seed in enumerate(seeds):
                obstacles = generate_map(name, np.random.default_rng(seed), size, size)
                ax = fig.add_subplot(len(families), cols, i * cols + j * len(seeds) + k + 1)
                ax.imshow(~obstacles, cmap="gray", vmin=0, vmax=1, interpolation="antialiased")
                ax.set_xticks([])
                ax.set_yticks([])
                if i == 0:
                    ax.set_title(f"{size} px, seed {seed}", fontsize=8)
                if j == 0 and k == 0:
                    ax.set_ylabel(name, fontsize=10)
                axes.append(ax)
    return axes


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--large", action="store_true",
                        help="the large-map families at 256 and 1024 px into docs/synth-families-large.png")
    parser.add_argument("--families", default=None, help="comma-separated family names (default: the first twelve)")
    parser.add_argument("--sizes", default=None, help="comma-separated map sides in px (default: 201,801; --large 256,1024)")
    parser.add_argument("--seeds", type=int, default=4, help="seeds 0..N-1 per size")
    parser.add_argument("--out", type=Path, default=None, help="output PNG")
    parser.add_argument("--dpi", type=int, default=110)
    args = parser.parse_args(argv)
    args.families = args.families or ",".join(LARGE_FAMILIES if args.large else FIRST)
    args.sizes = args.sizes or ("256,1024" if args.large else "201,801")
    args.out = args.out or DOCS / ("synth-families-large.png" if args.large else "synth-families.png")
    families = [f for f in args.families.split(",") if f]
    sizes = [int(s) for s in args.sizes.split(",") if s]
    seeds = list(range(args.seeds))
    cols = len(sizes) * len(seeds)
    fig = new_figure(figsize=(1.6 * cols, 1.65 * len(families)), dpi=args.dpi)
    draw_sheet(fig, families, sizes, seeds)
    fig.subplots_adjust(left=0.04, right=0.995, top=0.97, bottom=0.005, wspace=0.05, hspace=0.08)
    fig.canvas.draw()
    from PIL import Image  # the sheet is grey: an 8-bit greyscale PNG is a third of the RGBA one

    grey = Image.fromarray(np.asarray(fig.canvas.buffer_rgba())).convert("L")
    atomic_write(args.out, lambda fh: grey.save(fh, format="PNG", optimize=True))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
