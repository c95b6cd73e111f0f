"""Training on a weighted mixture of sources at several planning-grid scales.

A *source* is the paper's dataset (``paper``) or a generated set directory (``ndrql data generate``),
each with a weight: ``"paper:1,/data/gen-a:3"``. Every optimisation step draws one planning-grid
size ``n`` (all samples of a batch share the input side, :func:`ndrql.dataset.render.input_side`),
then for each sample a source by weight, a sample of it uniformly and a dihedral transform. All of it
derives from ``(seed, epoch, step)``, so a resumed run sees exactly the batches it would have seen.
The batch holds ``batch_size x (201 / side)^2`` samples (at least 2): about the same pixels per step
at every scale.

Validation uses fixed held-out samples of each source: the paper's validation split, and the last
:data:`VAL_FRACTION` of each generated set (never drawn for training).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

from ndrql.dataset.batches import transform_array, transform_point
from ndrql.dataset.cache import SplitArrays, unpack
from ndrql.dataset.encodings import encode_input, has_unknown
from ndrql.dataset.generated import GeneratedSet, check_training_set
from ndrql.dataset.render import DISTANCE_UNIT, Rendered, input_side, manhattan_pixels, render, render_belief_grid
from ndrql.errors import NdrqlError
from ndrql.maps.belief import Belief
from ndrql.maps.grid import MODEL_SIDE
from ndrql.synth.families import family_names
from ndrql.synth.labels import dilate_region, near_optimal_path

#: Share of each generated set held out for validation (its last samples).
VAL_FRACTION = 0.03
#: Tries to draw a usable sample before a step gives up (a mixture where most samples are unusable is a bug).
MAX_TRIES = 64


@dataclass(frozen=True)
class SourceSpec:
    """One entry of ``--sources``: ``paper`` or a generated set directory, and its weight."""

    name: str
    weight: float


def parse_sources(text: str) -> list[SourceSpec]:
    """``"paper:1,/dir/gen:3"`` -> specs (a missing weight is 1)."""
    out = []
    for part in (p.strip() for p in text.split(",")):
        if not part:
            continue
        name, weight = part, 1.0
        head, sep, tail = part.rpartition(":")
        if sep:
            try:
                name, weight = head, float(tail)
            except ValueError:
                name, weight = part, 1.0
        if not np.isfinite(weight) or weight <= 0:
            raise NdrqlError(f"source weight must be positive, got {part!r}")
        out.append(SourceSpec(name, weight))
    if not out:
        raise NdrqlError("no training source given (e.g. --sources paper:1,DIR:3)")
    return out


#: Largest planning grid a report or a native-view training draws (a native input is 4 px per cell).
MAX_SIZE = 256
#: Largest training grid under a view that bounds the input (``cap``/``coarse``): the top of the size ladder
#: ``plan`` climbs when a map does not connect at 256 cells, so the companion sees the grids it serves.
MAX_VIEW_SIZE = 512


def parse_sizes(text: str, largest: int = MAX_SIZE) -> tuple[int, ...]:
    """``"50,100"`` -> planning-grid sizes (each 8..``largest``)."""
    try:
        sizes = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise NdrqlError(f"grid sizes must be integers, got {text!r}") from None
    if not sizes or any(not 8 <= s <= largest for s in sizes):
        raise NdrqlError(f"grid sizes must be 8..{largest}, got {text!r}")
    return sizes


class Source:
    """Samples of one source as raw (map, start, goal, waypoints), split into train and validation."""

    def __init__(self, spec: SourceSpec, train_ids: np.ndarray, val_ids: np.ndarray, get, belief=None):
        self.spec, self.train_ids, self.val_ids, self._get = spec, train_ids, val_ids, get
        self._belief = belief

    def belief(self, i: int) -> Belief | None:
        """The belief stored with sample ``i`` (a generated set drawn with ``--masks``), else ``None``."""
        return None if self._belief is None else self._belief(i)

    def raw(self, i: int) -> tuple[np.ndarray, tuple[int, int], tuple[int, int], np.ndarray | None, np.ndarray | None]:
        """(obstacles, start, goal, waypoints or None, stored guideline or None) of sample ``i``."""
        return self._get(i)


def paper_source(spec: SourceSpec, data: SplitArrays, train_idx: np.ndarray, val_idx: np.ndarray) -> Source:
    """The paper's TRAIN split: its own labels where the input is the paper's (201 px map)."""

    def get(i: int):
        sr, sc, gr, gc = (int(v) for v in data.points[i])
        return data.obstacles(i), (sr, sc), (gr, gc), None, unpack(data.guideline[i])

    return Source(spec, np.asarray(train_idx), np.asarray(val_idx), get)


def parse_families(text: str) -> frozenset[str]:
    """``"maze,office"`` -> a set of map-engine family names (unknown names are an error)."""
    names = frozenset(f.strip() for f in text.split(",") if f.strip())
    unknown = sorted(names - set(family_names()))
    if unknown:
        raise NdrqlError(f"unknown family {', '.join(unknown)} (known: {', '.join(family_names())})")
    return names


def generated_source(spec: SourceSpec, val_fraction: float = VAL_FRACTION, exclude: frozenset[str] = frozenset()) -> Source:
    """A generated set; its last ``val_fraction`` of samples is the validation part. Samples of the
    families in ``exclude`` are in neither part (leave-families-out training)."""
    gs = GeneratedSet.load(Path(spec.name))
    check_training_set(gs)
    n = len(gs)
    n_val = max(1, int(round(val_fraction * n))) if n > 1 else 0
    if exclude:
        keep = ~np.isin(gs.families, sorted(exclude))
        ids = np.arange(n)
        train, val = ids[: n - n_val][keep[: n - n_val]], ids[n - n_val:][keep[n - n_val:]]
        if not len(train):
            raise NdrqlError(f"{spec.name}: no samples left after excluding {', '.join(sorted(exclude))}")
    else:
        train, val = np.arange(n - n_val), np.arange(n - n_val, n)

    def get(i: int):
        raw = gs.raw(i)
        return raw.obstacles, raw.start, raw.goal, raw.waypoints, None

    return Source(spec, train, val, get, gs.belief if gs.mask_kinds is not None else None)


def render_source_sample(src: Source, i: int, mode: str, n: int, view=None) -> Rendered | None:
    """Render sample ``i`` of ``src`` for ``mode`` at grid ``n`` (the paper's own labels at 201 px map mode);
    ``view``: how a grid-mode model sees large grids (:class:`ndrql.dataset.views.GridView`, default native)."""
    obstacles, start, goal, waypoints, stored_guide = src.raw(i)
    belief = src.belief(i)
    if belief is not None:
        if mode != "grid" or (view is not None and str(view) != "native"):
            raise NdrqlError(f"{src.spec.name} holds beliefs (--masks): they train grid-mode models under the native "
                             f"view (--input-mode grid, no --view)")
        return render_belief_grid(obstacles, belief.obstacles, belief.unknown, start, goal, n)
    if mode == "map" and stored_guide is not None:
        if input_side("map", n) == obstacles.shape[0] == obstacles.shape[1]:
            return Rendered(obstacles, start, goal, stored_guide, dilate_region(stored_guide))

        waypoints = near_optimal_path(obstacles, start, goal)
    return render(mode, obstacles, start, goal, waypoints, n, view)


def augment(r: Rendered, k: int) -> Rendered:
    """Dihedral transform ``k`` (0..7) of input, points and labels together."""
    if not k:
        return r
    shape = r.obstacles.shape
    return Rendered(transform_array(r.obstacles, k), transform_point(r.start, k, shape), transform_point(r.goal, k, shape),
                    transform_array(r.guideline, k), transform_array(r.region, k),
                    None if r.distance is None else transform_array(r.distance, k),
                    None if r.unknown is None else transform_array(r.unknown, k))


def batch_size_for(side: int, batch_size: int) -> int:
    """Samples per step at input side ``side``: about ``batch_size`` 201-px inputs' worth of pixels."""
    return max(2, int(round(batch_size * (MODEL_SIDE / side) ** 2)))


def stack(items: list[Rendered], encoding: str, distance: bool = False):
    """(x, region, guideline) float tensors (B, C, H, W); with ``distance`` also the distance head's label
    (B, 2, H, W), :func:`distance_target`."""
    import torch

    keep = has_unknown(encoding)  # a model without the channel sees the belief alone
    x = np.stack([encode_input(r.obstacles, r.start, r.goal, encoding, r.unknown if keep else None) for r in items])
    region = np.stack([r.region for r in items])[:, None].astype(np.float32)
    guide = np.stack([r.guideline for r in items])[:, None].astype(np.float32)
    out = (torch.from_numpy(x), torch.from_numpy(region), torch.from_numpy(guide))
    if not distance:
        return out
    d = np.stack([distance_target(r) for r in items])
    return out + (torch.from_numpy(d),)


def distance_target(r: Rendered) -> np.ndarray:
    """(2, side, side) float32: the detour ``(moves - manhattan) / DISTANCE_UNIT`` (-1 where unknown, everywhere
    for an item without distance) and the Manhattan distance ``/ DISTANCE_UNIT`` (:func:`manhattan_pixels`)."""
    side = r.region.shape[0]
    manh = manhattan_pixels(r.goal, side)
    if r.distance is None:
        detour = np.full((side, side), -1.0, np.float32)
    else:
        detour = np.where(r.distance >= 0, (r.distance - manh) / DISTANCE_UNIT, -1.0).astype(np.float32)
    return np.stack([detour, manh / DISTANCE_UNIT]).astype(np.float32)


class Mixture:
    """Weighted sources, input mode and grid sizes: deterministic batches and a fixed validation list."""

    def __init__(self, sources: list[Source], mode: str, sizes: tuple[int, ...], encoding: str = "point",
                 distance: bool = False, view=None):
        if not sources:
            raise NdrqlError("no training source")
        self.sources, self.mode, self.sizes, self.encoding = sources, mode, tuple(sizes), encoding
        self.distance = distance
        """Batches carry the goal-distance label as a fourth tensor (:func:`stack`)."""
        self.view = view
        """How a grid-mode model sees large grids (:class:`ndrql.dataset.views.GridView`; ``None``: native)."""
        w = np.array([s.spec.weight for s in sources], np.float64)
        self.p = w / w.sum()
        input_side(mode, sizes[0])  # validates the mode

    def batch(self, seed: int, epoch: int, step: int, batch_size: int, augment_on: bool = True):
        """Batch number ``step`` of ``epoch`` (a pure function of its arguments)."""
        rng = np.random.default_rng([seed, epoch, step, 7919])
        n = int(self.sizes[int(rng.integers(len(self.sizes)))])
        items = []
        side = self.view.side(n) if self.view is not None and self.mode == "grid" else input_side(self.mode, n)
        for _ in range(batch_size_for(side, batch_size)):
            for _try in range(MAX_TRIES):
                src = self.sources[int(rng.choice(len(self.sources), p=self.p))]
                i = int(src.train_ids[int(rng.integers(len(src.train_ids)))])
                k = int(rng.integers(8)) if augment_on else 0
                r = render_source_sample(src, i, self.mode, n, self.view)
                if r is not None:
                    items.append(augment(r, k))
                    break
            else:
                raise NdrqlError(f"no usable sample in {MAX_TRIES} draws at grid {n} ({self.mode} mode)")
        return stack(items, self.encoding, self.distance)

    def batches(self, seed: int, epoch: int, steps: int, batch_size: int, start_step: int = 0,
                augment_on: bool = True) -> Iterator[tuple[int, tuple]]:
        for step in range(start_step, steps):
            yield step, self.batch(seed, epoch, step, batch_size, augment_on)

    def validation(self, per_source: int = 64) -> list[tuple[str, Rendered]]:
        """Fixed validation inputs: up to ``per_source`` held-out samples per source, spread over the grid sizes."""
        out = []
        for src in self.sources:
            got = 0
            for j, i in enumerate(src.val_ids):
                if got >= per_source:
                    break
                n = self.sizes[j % len(self.sizes)]
                r = render_source_sample(src, int(i), self.mode, n, self.view)
                if r is not None:  # unusable at this grid (disconnected): the next held-out sample instead
                    out.append((Path(src.spec.name).name, r))
                    got += 1
        return out
