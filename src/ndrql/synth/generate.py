"""One generated training sample: a map of a family, a start/goal pair like the dataset's, its path.

Everything random in a sample derives from ``(seed, index)``, so sample ``i`` of a set is the same
whatever order, process or resume produced it. The labels themselves are not stored: they are
drawn from the waypoints at whatever scale the model is trained at (:mod:`ndrql.synth.labels`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ndrql.errors import NdrqlError
from ndrql.maps.problem import MapProblem
from ndrql.synth.belief_sets import parse_masks
from ndrql.synth.endpoints import sample_endpoints
from ndrql.synth.families import family_names, generate_map
from ndrql.synth.labels import near_optimal_path

#: Map draws tried per sample before giving up (a family that never yields a long start/goal pair is a bug).
MAX_DRAWS = 25


@dataclass(frozen=True)
class RawSample(MapProblem):
    """A map with start, goal and a near-optimal path at the map's own resolution (square maps)."""

    waypoints: np.ndarray
    """(K, 2) int waypoints from start to goal (8-connected optimum, line-of-sight shortcut)."""
    family: str
    """Name of the map family (``ndrql.synth.families``), or the dataset category."""


@dataclass(frozen=True)
class SetSpec:
    """What a generated set holds: families, map sizes, how many samples, and the seed."""

    families: tuple[str, ...]
    """Families drawn round-robin (sample ``i`` is of family ``families[i % len(families)]``)."""
    sizes: tuple[int, ...]
    """Map sides in pixels; each sample draws one uniformly (square maps)."""
    count: int
    """Number of samples."""
    seed: int
    """Seed of the whole set; sample ``i`` draws from ``np.random.default_rng([seed, i])``."""
    masks: str = ""
    """Beliefs drawn beside each map (:mod:`ndrql.synth.belief_sets`, e.g. ``blobs:0.1-0.5,sensed,outdated,none:0.2``);
    empty: none (the set holds true maps only)."""
    mask_seed: int = 0
    """Seed of the beliefs (with ``masks``); sample ``i``'s belief draws from ``default_rng([mask_seed, i, 54])``."""

    def __post_init__(self) -> None:
        known = family_names()
        bad = [f for f in self.families if f not in known]
        if not self.families or bad:
            raise NdrqlError(f"unknown family {', '.join(bad) or '(none given)'}; valid: {', '.join(known)}")
        if not self.sizes or any(not 32 <= s <= 4096 for s in self.sizes):
            raise NdrqlError(f"map sizes must be 32..4096 px, got {list(self.sizes)}")
        if not 1 <= self.count <= 10_000_000:
            raise NdrqlError(f"count must be 1..10000000, got {self.count}")
        if not 0 <= self.seed < 2**63:
            raise NdrqlError(f"seed must be 0..2^63-1, got {self.seed}")
        if not 0 <= self.mask_seed < 2**63:
            raise NdrqlError(f"mask seed must be 0..2^63-1, got {self.mask_seed}")
        if self.masks:
            object.__setattr__(self, "masks", str(parse_masks(self.masks)))  # one spelling per spec

    def to_dict(self) -> dict:
        """Plain form for the manifest (``masks`` and ``mask_seed`` only when the set draws beliefs, so a set
        without them keeps the manifest it always had)."""
        out = {"families": list(self.families), "sizes": list(self.sizes), "count": self.count, "seed": self.seed}
        return {**out, "masks": self.masks, "mask_seed": self.mask_seed} if self.masks else out

    @classmethod
    def from_dict(cls, d: dict) -> "SetSpec":
        return cls(tuple(d["families"]), tuple(int(s) for s in d["sizes"]), int(d["count"]), int(d["seed"]),
                   str(d.get("masks", "")), int(d.get("mask_seed", 0)))


def generate_sample(spec: SetSpec, index: int) -> RawSample:
    """Sample ``index`` of the set ``spec`` (deterministic: same spec and index, same sample)."""
    family = spec.families[index % len(spec.families)]
    rng = np.random.default_rng([spec.seed, index])
    size = int(spec.sizes[int(rng.integers(len(spec.sizes)))])
    for _ in range(MAX_DRAWS):
        obstacles = generate_map(family, rng, size, size)
        pair = sample_endpoints(rng, obstacles)
        if pair is None:
            continue
        start, goal = pair
        waypoints = near_optimal_path(obstacles, start, goal)
        return RawSample(obstacles, tuple(map(int, start)), tuple(map(int, goal)), np.asarray(waypoints, np.int32), family)
    raise NdrqlError(f"family {family!r} gave no usable start/goal pair in {MAX_DRAWS} maps of {size} px (seed {spec.seed}, sample {index})")
