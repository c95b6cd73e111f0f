"""The Q-table drawn as four triangles per cell, one per action (paper Fig. 3 and Fig. 6, row 3).

Each cell of the planning grid is split along its diagonals; the triangle on the side an action
moves to (up = top, down = bottom, left, right) is coloured by that action's Q-value.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ndrql.planning.rules import ACTION_NAMES
from ndrql.viz.maps import plot_occupancy


def qtable_triangles(shape: tuple[int, int]) -> np.ndarray:
    """Vertices ``(h * w * 4, 3, 2)`` as ``(x = col, y = row)`` of every cell's four triangles,
    ordered cell-major then by action (up, down, left, right), cell centres at integer coordinates."""
    h, w = shape
    rr, cc = np.meshgrid(np.arange(h, dtype=float), np.arange(w, dtype=float), indexing="ij")
    x, y = cc.ravel(), rr.ravel()
    c = np.stack([x, y], -1)
    tl, tr = np.stack([x - 0.5, y - 0.5], -1), np.stack([x + 0.5, y - 0.5], -1)
    bl, br = np.stack([x - 0.5, y + 0.5], -1), np.stack([x + 0.5, y + 0.5], -1)
    corners = {"up": (tl, tr), "down": (bl, br), "left": (tl, bl), "right": (tr, br)}
    tris = np.stack([np.stack([c, *corners[a]], 1) for a in ACTION_NAMES], 1)  # (cells, 4, 3, 2)
    return tris.reshape(-1, 3, 2)


def plot_qtable(ax: Any, q: np.ndarray, shape: tuple[int, int], *, blocked: np.ndarray | None = None,
                cmap: str = "viridis", vmin: float | None = None, vmax: float | None = None,
                clip_percentile: float | None = 1.0) -> list[Any]:
    """Draw ``q`` (``(h * w, 4)``) as four triangles per cell; blocked cells are drawn black.

    Colour limits default to the ``clip_percentile``-th and ``100 - clip_percentile``-th percentile
    of the free cells' values, so a few extreme values do not wash out the picture. Returns the
    ``PolyCollection`` (and the blocked-cell image when drawn).
    """
    from matplotlib.collections import PolyCollection

    h, w = shape
    q = np.asarray(q, dtype=np.float64)
    if q.shape != (h * w, 4):
        raise ValueError(f"q must have shape ({h * w}, 4) for a {h}x{w} grid, got {q.shape}")
    free = np.ones(h * w, bool) if blocked is None else ~np.asarray(blocked, bool).ravel()
    vals = q[free].ravel()
    if vals.size and clip_percentile:
        lo, hi = np.percentile(vals, [clip_percentile, 100 - clip_percentile])
    else:
        lo, hi = (float(vals.min()), float(vals.max())) if vals.size else (0.0, 1.0)
    vmin = lo if vmin is None else vmin
    vmax = hi if vmax is None else vmax
    if vmax <= vmin:
        vmax = vmin + 1e-9
    tris = qtable_triangles(shape)
    keep = np.repeat(free, 4)
    coll = PolyCollection(tris[keep], array=q.ravel()[keep], cmap=cmap, edgecolors="none")
    coll.set_clim(vmin, vmax)
    artists: list[Any] = [ax.add_collection(coll)]
    if blocked is not None:
        artists.append(plot_occupancy(ax, blocked, color="black", zorder=2))
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    ax.set_aspect("equal")
    return artists
