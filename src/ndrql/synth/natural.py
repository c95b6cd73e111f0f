"""Natural map families: caves and open outdoor areas with irregular walls, as game maps draw them.

Look-alikes of the published descriptions of game benchmark maps (caverns of role-playing games,
outdoor areas with lakes, cliffs, rivers and woods), drawn from smoothed random noise: a field that
sums noise at a few scales, thresholded at the quantile that gives the wanted obstacle share, so
walls are ragged at every scale. Free areas cut off by the threshold are joined to the main area
by tunnels or filled (:func:`ndrql.synth.shapes.join_free_areas`), as a game map marks unreachable
ground out of bounds. Every random choice comes from the ``np.random.Generator`` passed in.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ndrql.synth.shapes import (check_px, check_range, disc, feature_px, join_free_areas, paint_rects,
                                redraw_until_open, smooth_noise, stamp)


def noise_field(rng: np.random.Generator, shape: tuple[int, int], scale: int, rough: float) -> np.ndarray:
    """Smooth noise with blobs about ``scale`` px across, plus half and quarter scales (weights 1, 0.5, 0.25),
    plus ``rough`` times pixel-scale noise for ragged outlines."""
    field = np.zeros(shape, np.float32)
    for k, weight in ((1, 1.0), (2, 0.5), (4, 0.25)):
        field += weight * smooth_noise(rng, shape, max(1, scale // k))
    if rough > 0:
        field += rough * smooth_noise(rng, shape, max(2, scale // 8))
    return field


def threshold_share(field: np.ndarray, share: float, smooth: int = 2) -> np.ndarray:
    """``True`` on the ``share`` of pixels with the lowest values of ``field`` (ties kept together), then
    ``smooth`` steps of the cellular-automaton rule of cave generators (a pixel becomes rock when most of
    its 3x3 neighbourhood is), which removes specks and keeps ragged outlines."""
    out = field <= np.quantile(field, share)
    for _ in range(smooth):
        out = ndimage.uniform_filter(out.astype(np.float32), 3, mode="nearest") > 0.5
    return out


def _border(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    """A ragged rock border 1-3 % of the longer side thick (on 70 % of maps; none otherwise)."""
    out = np.zeros((h, w), bool)
    if rng.random() >= 0.7:
        return out
    t = max(1, int(rng.uniform(0.01, 0.03) * max(h, w)))
    edge = np.minimum(np.minimum(np.arange(h)[:, None], np.arange(h)[::-1, None]),
                      np.minimum(np.arange(w)[None, :], np.arange(w)[None, ::-1]))
    jitter = smooth_noise(rng, (h, w), max(2, t * 2)) * t
    return edge < 0.5 * t + jitter


def _cave_once(rng: np.random.Generator, h: int, w: int, rock: float | None, scale: int | None) -> np.ndarray:
    L = max(h, w)
    s = feature_px(rng, L, px=(8, 160), rel=(0.03, 0.12), given=scale)
    share = rock if rock is not None else rng.uniform(0.38, 0.56)
    out = threshold_share(-noise_field(rng, (h, w), s, rng.uniform(0.05, 0.3)), share) | _border(rng, h, w)
    tunnel = max(1, int(round(s * rng.uniform(0.15, 0.4))))
    return join_free_areas(out, tunnel, min_area=max(4, s * s // 4))


def cave(rng: np.random.Generator, height: int, width: int, *, rock: float | None = None,
         scale: int | None = None) -> np.ndarray:
    """Caverns joined by winding passages: thresholded multi-scale noise with a ragged rock border.

    Randomises the share of ``rock`` before tunnels and fills (0.38-0.56), the ``scale`` of the
    caverns (1.5-12 % of the longer side, clipped to 4-160 px; half and quarter scales are added),
    the roughness of the walls, a rock border on 70 % of maps (1-3 % thick, ragged) and the width of
    the tunnels that join cut-off caverns of at least a quarter scale squared to the main cave
    (0.15-0.4 scale); smaller pockets are filled. The free space is one 8-connected area.
    """
    check_range("rock", rock, 0.05, 0.8)
    check_px(height, width, scale=scale)
    return redraw_until_open(lambda: _cave_once(rng, height, width, rock, scale))


def _river(rng: np.random.Generator, h: int, w: int, width: int) -> np.ndarray:
    """A meandering river across the rows (top to bottom), ``width`` px wide, with 1-3 fords or bridges."""
    rows = np.arange(h)
    wiggle = smooth_noise(rng, (h, 1), max(2, h // int(rng.integers(2, 6))))[:, 0]
    wiggle = (wiggle - wiggle.mean()) / (np.ptp(wiggle) + 1e-9)
    centre = rng.uniform(0.25, 0.75) * w + wiggle * rng.uniform(0.1, 0.5) * w
    c0 = np.clip(np.rint(centre - width / 2).astype(np.int64), 0, w)
    out = paint_rects((h, w), np.stack([rows, c0, rows + 1, c0 + width], axis=1))
    for _ in range(int(rng.integers(1, 4))):
        r = int(rng.integers(0, h))
        span = max(2, int(width * rng.uniform(0.5, 1.5)))
        out[max(0, r - span // 2): r + span // 2 + 1, :] = False
    return out


def _outdoor_once(rng: np.random.Generator, h: int, w: int, cover: float | None, scale: int | None) -> np.ndarray:
    L = max(h, w)
    s = feature_px(rng, L, px=(6, 300), rel=(0.03, 0.25), given=scale)
    share = cover if cover is not None else rng.uniform(0.08, 0.3)
    out = threshold_share(-noise_field(rng, (h, w), s, rng.uniform(0.1, 0.5)), share)  # lakes, cliffs, rock
    if rng.random() < 0.5:  # a river across the map, through the long side half the time
        width = max(2, int(rng.uniform(0.01, 0.05) * L))
        out |= _river(rng, h, w, width) if rng.random() < 0.5 else _river(rng, w, h, width).T
    trees = rng.uniform(0.0, 0.12)
    if trees > 0:  # woods: small discs, denser where a second noise field is high
        d = max(1, int(rng.uniform(0.003, 0.012) * L))
        n = int(trees * h * w / max(1, d * d))
        wood = smooth_noise(rng, (h, w), max(2, s))
        r, c = rng.integers(0, h, 3 * n), rng.integers(0, w, 3 * n)
        keep = rng.random(3 * n) < wood[r, c] ** 2
        stamp(out, r[keep][:n] - d // 2, c[keep][:n] - d // 2, disc(d))
    out |= _border(rng, h, w) & (rng.random() < 0.5)
    path = max(2, int(rng.uniform(0.005, 0.02) * L))
    return join_free_areas(out, path, min_area=max(8, (s // 2) ** 2))


def outdoor(rng: np.random.Generator, height: int, width: int, *, cover: float | None = None,
            scale: int | None = None) -> np.ndarray:
    """Open natural ground with lakes, cliffs and woods, sometimes a river with fords: mostly free, irregular walls.

    Randomises the ``cover`` of lakes and cliffs (0.08-0.30 of the map, thresholded multi-scale
    noise), their ``scale`` (3-25 % of the longer side, clipped to 6-300 px), the roughness of their
    shores, a meandering river across the map (half the maps; 1-5 % wide, 1-3 crossings), woods of
    small discs (0-12 % of the map, 0.3-1.2 % across, clustered by a second noise field) and a
    ragged border (a third of the maps). Cut-off pockets are joined by paths or filled.
    """
    check_range("cover", cover, 0.0, 0.6)
    check_px(height, width, scale=scale)
    return redraw_until_open(lambda: _outdoor_once(rng, height, width, cover, scale))
