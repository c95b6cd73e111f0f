"""The evaluation sets of generated maps: one registry, two roles, and the seal.

``transfer_sets.json`` names every set (families, map sizes, count, seed) with its **role**:

- ``development``: seeds in :data:`~ndrql.limits.DEVELOPMENT_SEEDS`. These sets are used to choose
  (``tune`` searches constants, ``select`` picks weights and presets, ``transfer`` is the
  development report that choices were also read from), so their figures are development figures.
- ``sealed``: seeds in :data:`~ndrql.limits.SEALED_SEEDS`. Evaluated only by ``ndrql reproduce
  release``, which verifies the maps against the digests recorded when the set was drawn
  (``set_digests.json``) and counts every run in a committed ledger.

A role and a seed range must agree (a sealed set has a sealed seed, and the reverse); every other
command is refused a sealed set, whether it is named by the registry or built from a sealed seed.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from ndrql.dataset.cache import cache_dir
from ndrql.dataset.generated import GeneratedSet, generate_set, read_manifest
from ndrql.errors import NdrqlError
from ndrql.experiments.digests import fingerprint
from ndrql.limits import SEALED_SEEDS, seed_role
from ndrql.synth.generate import SetSpec

REGISTRY = "transfer_sets.json"
"""The registry file (package data of ``ndrql.experiments``)."""
DIGESTS = "set_digests.json"
"""Per-map and per-problem digests of every registered set, recorded when it was drawn (package data)."""
ROLES = ("development", "sealed")


@dataclass(frozen=True)
class EvalSet:
    """One registered evaluation set."""

    name: str
    role: str
    """``development`` or ``sealed`` (module docstring)."""
    use: str
    """What the set is for, in a few words (printed by reports)."""
    spec: SetSpec
    grids: tuple[int, ...] = (50, 100)
    """The planning grids the set is drawn for, which the release report reads it at by default."""


def _check_entry(name: str, entry: dict) -> EvalSet:
    role = entry.get("role")
    if role not in ROLES:
        raise NdrqlError(f"{REGISTRY}: set {name!r} has role {role!r}; valid: {', '.join(ROLES)}")
    spec = SetSpec.from_dict(entry)
    if seed_role(spec.seed) != role:
        raise NdrqlError(f"{REGISTRY}: set {name!r} is {role} but its seed {spec.seed} is a {seed_role(spec.seed)} seed")
    return EvalSet(name, role, str(entry.get("use", "")), spec, tuple(int(n) for n in entry.get("grids", (50, 100))))


def parse_registry(data: dict) -> dict[str, EvalSet]:
    """The sets of a registry document, checked: known role, a seed in that role's range, no seed twice."""
    sets = {name: _check_entry(name, entry) for name, entry in data["sets"].items()}
    seeds = [s.spec.seed for s in sets.values()]
    if len(set(seeds)) != len(seeds):
        raise NdrqlError(f"{REGISTRY}: two sets share a seed ({sorted(seeds)})")
    return sets


def registry() -> dict[str, EvalSet]:
    """Every registered evaluation set by name (:func:`parse_registry` of the package's file)."""
    return parse_registry(json.loads(resources.files("ndrql.experiments").joinpath(REGISTRY).read_text()))


def sealed_names() -> list[str]:
    """Names of the sealed sets, in registry order."""
    return [name for name, s in registry().items() if s.role == "sealed"]


def _sealed(what: str) -> NdrqlError:
    dev = ", ".join(n for n, s in registry().items() if s.role == "development")
    return NdrqlError(f"{what} is sealed: only `ndrql reproduce release` evaluates it (development sets: {dev})")


def check_not_sealed(spec: SetSpec) -> None:
    """Refuse ``spec`` if its seed is a sealed seed (whatever the registry says): only the release report reads those."""
    if spec.seed in SEALED_SEEDS:
        raise _sealed(f"a set with seed {spec.seed}")


def eval_spec(name: str = "transfer", *, release: bool = False) -> SetSpec:
    """The registered set ``name``; a sealed one only for the release report (``release=True``)."""
    sets = registry()
    if name not in sets:
        raise NdrqlError(f"unknown evaluation set {name!r}; valid: {', '.join(sets)}")
    entry = sets[name]
    if not release and (entry.role == "sealed" or entry.spec.seed in SEALED_SEEDS):
        raise _sealed(f"set {name!r}")
    return entry.spec


#: Development sets a search must not tune on: the development report and the set that checks what a search found.
NOT_FOR_TUNING = ("transfer", "select")


def tuning_spec(name: str) -> SetSpec:
    """The set ``name`` for a search of constants: refused for a sealed set and for :data:`NOT_FOR_TUNING`."""
    spec = eval_spec(name)
    if name in NOT_FOR_TUNING:
        raise NdrqlError(f"the {name!r} set reports or checks what a search chose; tune on 'tune'")
    return spec


def eval_set(spec: SetSpec, progress: bool = True, *, release: bool = False) -> GeneratedSet:
    """The evaluation set in the cache (generated on first use; same spec, same bytes). A sealed seed only
    with ``release=True``, and then the maps must match the recorded digests (:func:`verify_seal`)."""
    if not release:
        check_not_sealed(spec)
    root = cache_dir() / "gen" / f"eval-{fingerprint(spec.to_dict())}"
    if not (root / "manifest.json").exists() or read_manifest(root)["spec"] != spec.to_dict():
        generate_set(root, spec, workers=2, progress=progress, purpose="evaluation")
    return GeneratedSet.load(root)


def _digest(side: int, packed: bytes) -> str:
    return hashlib.sha256(int(side).to_bytes(4, "little") + packed).hexdigest()[:16]


def map_digest(obstacles: np.ndarray) -> str:
    """First 16 hex digits of the SHA-256 of a square map: its side and its bit-packed cells."""
    return _digest(obstacles.shape[0], np.packbits(np.asarray(obstacles, bool).ravel()).tobytes())


def problem_digest(map_id: str, start: tuple[int, int], goal: tuple[int, int]) -> str:
    """First 16 hex digits of the SHA-256 of a problem: its map's digest, start and goal."""
    return hashlib.sha256(map_id.encode() + np.asarray([*start, *goal], np.int64).tobytes()).hexdigest()[:16]


def set_record(gs: GeneratedSet) -> dict:
    """What the digest file holds for a set: its spec, and the digest of each map and each problem (the
    maps are hashed as stored, bit-packed, without unpacking them)."""
    maps = [_digest(int(gs.sizes[i]), gs.maps[gs.map_offsets[i]:gs.map_offsets[i + 1]].tobytes()) for i in range(len(gs))]
    pts = np.asarray(gs.points, np.int64)
    return {"spec": gs.spec.to_dict(), "maps": maps,
            "problems": [problem_digest(m, tuple(pts[i, :2]), tuple(pts[i, 2:])) for i, m in enumerate(maps)]}


def recorded_digests() -> dict:
    """The digest file (``{"sets": {name: record}, "training": {label: record}}``)."""
    return json.loads(resources.files("ndrql.experiments").joinpath(DIGESTS).read_text())


def verify_seal(name: str, gs: GeneratedSet) -> None:
    """Refuse a set whose maps or problems differ from those recorded when ``name`` was drawn (a changed
    generator makes another set: it would not be the sealed one)."""
    rec = recorded_digests()["sets"].get(name)
    if rec is None:
        raise NdrqlError(f"set {name!r} has no recorded digests in {DIGESTS}: draw and record it first (tools/seal_sets.py)")
    now = set_record(gs)
    if now != {k: rec.get(k) for k in now}:
        bad = sum(a != b for a, b in zip(now["problems"], rec["problems"])) + abs(len(now["problems"]) - len(rec["problems"]))
        raise NdrqlError(f"set {name!r} does not match its recorded digests ({bad} problems differ, spec "
                         f"{'same' if now['spec'] == rec['spec'] else 'changed'}): the generator changed; this is not the sealed set")


def digests_path() -> Path:
    """Where the digest file lives in a source checkout (tools/seal_sets.py writes it)."""
    return Path(str(resources.files("ndrql.experiments").joinpath(DIGESTS)))
