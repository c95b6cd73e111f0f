"""Generated sample sets on disk: written by ``ndrql data generate``, read by training and evaluation.

Layout of a set directory::

    manifest.json          {"format": "ndrql-generated", "version": 1, "spec": {...}, "shard_size": K}
    shard-00000.npz        samples 0..K-1
    shard-00001.npz        samples K..2K-1, ...

A shard holds, per sample: the bit-packed square map (concatenated, with offsets), start and goal
``(row, col)``, the waypoints of the near-optimal path (concatenated, with offsets) and the family.
Shards are written atomically and each is a pure function of ``(spec, shard index)``, so an
interrupted ``generate`` resumes by writing the missing shards, and any process count gives the same
bytes.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ndrql.errors import DatasetError, NdrqlError
from ndrql.io import file_digest, save_npz, write_json, write_text
from ndrql.io.text import load_json, read_capped
from ndrql.maps.belief import Belief
from ndrql.limits import DEVELOPMENT_SEEDS, SEALED_SEEDS, check_training_seed
from ndrql.synth.belief_sets import KIND_CODES, draw_training_belief, kind_code, parse_masks
from ndrql.synth.generate import RawSample, SetSpec, generate_sample
from ndrql.workers import process_pool

FORMAT = "ndrql-generated"
VERSION = 1
#: Samples per shard file.
SHARD_SIZE = 256
#: Largest manifest read (bytes).
MAX_MANIFEST_BYTES = 1 << 20


def shard_path(root: Path, k: int) -> Path:
    return root / f"shard-{k:05d}.npz"


def n_shards(count: int, shard_size: int = SHARD_SIZE) -> int:
    return -(-count // shard_size)


def build_shard(spec: SetSpec, k: int, shard_size: int = SHARD_SIZE) -> dict[str, np.ndarray]:
    """The arrays of shard ``k`` (samples ``k * shard_size`` .. up to ``spec.count``)."""
    lo, hi = k * shard_size, min(spec.count, (k + 1) * shard_size)
    samples = [generate_sample(spec, i) for i in range(lo, hi)]
    maps = [np.packbits(s.obstacles.ravel()) for s in samples]
    wps = [np.asarray(s.waypoints, np.int32).reshape(-1, 2) for s in samples]
    out = {
        "index": np.arange(lo, hi, dtype=np.int64),
        "sizes": np.array([s.obstacles.shape[0] for s in samples], np.int32),
        "points": np.array([s.start + s.goal for s in samples], np.int32).reshape(-1, 4),
        "families": np.array([s.family for s in samples], dtype="U32"),
        "map_offsets": np.concatenate([[0], np.cumsum([len(m) for m in maps])]).astype(np.int64),
        "maps": np.concatenate(maps) if maps else np.zeros(0, np.uint8),
        "wp_offsets": np.concatenate([[0], np.cumsum([len(w) for w in wps])]).astype(np.int64),
        "waypoints": np.concatenate(wps) if wps else np.zeros((0, 2), np.int32),
    }
    return {**out, **belief_arrays(spec, samples, lo)} if spec.masks else out


def belief_arrays(spec: SetSpec, samples: list[RawSample], lo: int) -> dict[str, np.ndarray]:
    """The beliefs of a set drawn with ``--masks`` (:mod:`ndrql.synth.belief_sets`): per sample the kind's code,
    the believed obstacles and the unknown pixels, bit-packed at the map's size like the maps (offsets shared)."""
    mask_spec = parse_masks(spec.masks)
    beliefs = [draw_training_belief(mask_spec, s.obstacles, s.start, s.goal, spec.mask_seed, lo + j)
               for j, s in enumerate(samples)]
    packed = lambda key: np.concatenate([np.packbits(getattr(b, key).ravel()) for b in beliefs]) if beliefs \
        else np.zeros(0, np.uint8)  # noqa: E731
    return {"mask_kinds": np.array([kind_code(b) for b in beliefs], np.int8), "believed": packed("obstacles"),
            "unknown": packed("unknown")}


def _write_shard(args: tuple[str, dict, int, int]) -> int:
    root, spec_dict, k, shard_size = args
    spec = SetSpec.from_dict(spec_dict)
    arrays = build_shard(spec, k, shard_size)
    path = save_npz(shard_path(Path(root), k), arrays, compressed=False)
    write_text(digest_path(Path(path)), file_digest(path) + "\n")
    return len(arrays["index"])


#: Arrays every shard holds.
SHARD_KEYS = ("index", "sizes", "points", "families", "map_offsets", "maps", "wp_offsets", "waypoints")
#: Arrays the shards of a set drawn with ``--masks`` hold besides (:func:`belief_arrays`).
BELIEF_KEYS = ("mask_kinds", "believed", "unknown")


def digest_path(path: Path) -> Path:
    """The file holding the SHA-256 of the shard ``path`` (as for the dataset cache)."""
    return path.with_name(path.name + ".sha256")


def read_shard(root: Path, k: int, count: int, shard_size: int, masks: bool = False) -> dict[str, np.ndarray]:
    """The arrays of shard ``k``, checked (digest when recorded, keys, lengths, offsets); :class:`DatasetError`
    naming the file and how to rebuild it when it is missing, damaged or inconsistent."""
    path = shard_path(root, k)
    if not path.exists():
        raise DatasetError(f"{root} is incomplete (no {path.name}); run the same `ndrql data generate` again to finish it")
    why = _shard_problem(path, k, count, shard_size, masks)
    if isinstance(why, str):
        raise DatasetError(f"damaged shard {path} ({why}); delete it and run the same `ndrql data generate --out "
                           f"{root} ...` again to rebuild it")
    return why


def _shard_problem(path: Path, k: int, count: int, shard_size: int, masks: bool = False) -> dict[str, np.ndarray] | str:
    """The shard's arrays, or why they cannot be used (``masks``: a set drawn with beliefs, :data:`BELIEF_KEYS`)."""
    try:
        recorded = digest_path(path).read_text().strip()
    except FileNotFoundError:
        recorded = None  # written without a digest (killed in between): trusted when it checks out
    except OSError as exc:
        return f"unreadable digest ({exc.strerror})"
    if recorded is not None and file_digest(path) != recorded:
        return "its SHA-256 does not match the one recorded"
    try:
        with np.load(path, allow_pickle=False) as z:
            keys = SHARD_KEYS + (BELIEF_KEYS if masks else ())
            if set(z.files) != set(keys):
                return f"arrays {sorted(z.files)[:10]}, expected {list(keys)}"
            arrays = {key: z[key] for key in keys}
    except Exception as exc:  # zipfile, zlib, numpy: many types for a cut or corrupt file
        return type(exc).__name__
    n = min(count, (k + 1) * shard_size) - k * shard_size
    index, mo, wo = arrays["index"], arrays["map_offsets"], arrays["wp_offsets"]
    ok = (index.shape == (n,) and np.array_equal(index, np.arange(k * shard_size, k * shard_size + n))
          and arrays["sizes"].shape == (n,) and arrays["points"].shape == (n, 4) and arrays["families"].shape == (n,)
          and mo.shape == (n + 1,) and wo.shape == (n + 1,) and int(mo[0]) == 0 and int(wo[0]) == 0
          and bool(np.all(np.diff(mo) >= 0)) and bool(np.all(np.diff(wo) >= 0))
          and int(mo[-1]) == arrays["maps"].size and int(wo[-1]) == len(arrays["waypoints"])
          and bool(np.all(arrays["sizes"] > 0))
          and bool(np.all(np.diff(mo) * 8 >= arrays["sizes"].astype(np.int64) ** 2)))
    if ok and masks:
        ok = (arrays["mask_kinds"].shape == (n,) and arrays["believed"].shape == arrays["maps"].shape
              and arrays["unknown"].shape == arrays["maps"].shape)
    return arrays if ok else "its arrays do not fit together"


def read_manifest(root: str | Path) -> dict:
    """The manifest of a generated set; :class:`DatasetError` when missing or not one."""
    path = Path(root) / "manifest.json"
    if not path.exists():
        raise DatasetError(f"not a generated set (no manifest.json): {root}")
    data = load_json(read_capped(path, "manifest", MAX_MANIFEST_BYTES, DatasetError), f"manifest {path}", DatasetError)
    if not isinstance(data, dict) or data.get("format") != FORMAT or data.get("version") != VERSION:
        raise DatasetError(f"{path} is not a version-{VERSION} {FORMAT} manifest")
    size = data.get("shard_size")
    if isinstance(size, bool) or not isinstance(size, int) or not 1 <= size <= 1 << 20 or "spec" not in data:
        raise DatasetError(f"{path} is damaged (shard size or spec); run `ndrql data generate` into a new folder")
    return data


#: What a generated set is for: its seed must be in the matching range of :mod:`ndrql.limits`.
PURPOSES = ("training", "evaluation")


def check_purpose(seed: int, purpose: str) -> None:
    """Refuse a set seed outside the range of ``purpose``: ``training`` takes :data:`~ndrql.limits.TRAINING_SEEDS`
    only (maps a model or preset learns from never come from an evaluation seed), ``evaluation`` the
    development or sealed ranges (the registry of evaluation sets, ``ndrql.experiments.eval_sets``)."""
    if purpose not in PURPOSES:
        raise ValueError(f"purpose must be one of {', '.join(PURPOSES)}, got {purpose!r}")
    if purpose == "training":
        try:
            check_training_seed(seed, "--seed")
        except ValueError as exc:
            raise NdrqlError(str(exc)) from None
    elif seed not in DEVELOPMENT_SEEDS and seed not in SEALED_SEEDS:
        raise NdrqlError(f"evaluation sets take seeds {DEVELOPMENT_SEEDS.start}..{SEALED_SEEDS.stop - 1:,}, got {seed}")


def check_training_seed_of(root: str | Path, seed: int) -> None:
    """Refuse to train on the generated set at ``root`` drawn with ``seed`` if that is an evaluation seed."""
    try:
        check_purpose(seed, "training")
    except NdrqlError:
        raise NdrqlError(f"{root} was drawn with seed {seed}, an evaluation seed: it cannot be a "
                         f"training source (training seeds are 0..{DEVELOPMENT_SEEDS.start - 1:,})") from None


def check_training_set(gs: "GeneratedSet") -> None:
    """Refuse to train on a generated set drawn from an evaluation seed (:func:`check_purpose`)."""
    check_training_seed_of(gs.root, gs.spec.seed)


def check_training_dir(root: str | Path) -> None:
    """:func:`check_training_set` from the manifest alone (before any shard is read)."""
    check_training_seed_of(root, int(read_manifest(root)["spec"]["seed"]))


def generate_set(root: str | Path, spec: SetSpec, workers: int = 1, progress: bool = True,
                 shard_size: int = SHARD_SIZE, log: Callable[[str], None] | None = None,
                 purpose: str = "training") -> Path:
    """Write (or complete) the set ``spec`` under ``root``; returns ``root``.

    An existing set with another spec is refused, never mixed or replaced. Missing shards are
    written; existing ones are kept (each shard is written atomically, so none is ever partial).
    ``purpose``: ``training`` (``ndrql data generate``) refuses a seed outside the training range,
    ``evaluation`` (the registry's sets) one outside the evaluation ranges (:func:`check_purpose`).
    """
    from tqdm import tqdm

    check_purpose(spec.seed, purpose)
    if spec.masks:
        try:
            check_purpose(spec.mask_seed, purpose)
        except NdrqlError as exc:
            raise NdrqlError(str(exc).replace("--seed", "--mask-seed", 1)) from None
    root = Path(root)
    if root.exists() and not root.is_dir():
        raise NdrqlError(f"--out {root} exists and is not a directory")
    manifest = {"format": FORMAT, "version": VERSION, "spec": spec.to_dict(), "shard_size": shard_size}
    if (root / "manifest.json").exists():
        old = read_manifest(root)
        if old["spec"] != manifest["spec"] or old.get("shard_size") != shard_size:
            raise NdrqlError(f"{root} holds another set ({old['spec']}); choose another --out")
    else:
        if root.exists() and any(root.iterdir()):
            raise NdrqlError(f"--out {root} is a non-empty directory without a manifest; choose an empty or new one")
        root.mkdir(parents=True, exist_ok=True)
        write_json(root / "manifest.json", manifest, indent=1)
    todo = [k for k in range(n_shards(spec.count, shard_size))  # missing or damaged shards are (re)written
            if not shard_path(root, k).exists()
            or isinstance(_shard_problem(shard_path(root, k), k, spec.count, shard_size, bool(spec.masks)), str)]
    done = spec.count - sum(min(spec.count, (k + 1) * shard_size) - k * shard_size for k in todo)
    if log and done:
        log(f"resuming: {done} of {spec.count} samples already in {root}")
    jobs = [(str(root), spec.to_dict(), k, shard_size) for k in todo]
    with tqdm(total=spec.count, initial=done, desc="generate", unit="map", disable=not progress) as bar:
        if workers <= 1:
            for job in jobs:
                bar.update(_write_shard(job))
        else:
            with process_pool(workers) as pool:  # workers die with this process
                for n in pool.map(_write_shard, jobs):
                    bar.update(n)
    return root


@dataclass
class GeneratedSet:
    """A generated set held in memory (packed maps): ``len(s)``, ``s.raw(i)``, ``s.families``."""

    root: Path
    spec: SetSpec
    sizes: np.ndarray
    points: np.ndarray
    families: np.ndarray
    map_offsets: np.ndarray
    maps: np.ndarray
    wp_offsets: np.ndarray
    waypoints: np.ndarray
    mask_kinds: np.ndarray | None = None
    """Per sample the code of its belief's kind (:data:`ndrql.synth.belief_sets.KIND_CODES`); ``None``: no beliefs."""
    believed: np.ndarray | None = None
    """Packed believed obstacles per sample (offsets as the maps'), with ``--masks``."""
    unknown: np.ndarray | None = None
    """Packed unknown pixels per sample (offsets as the maps'), with ``--masks``."""

    @classmethod
    def load(cls, root: str | Path) -> "GeneratedSet":
        root = Path(root)
        manifest = read_manifest(root)
        try:
            spec = SetSpec.from_dict(manifest["spec"])
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise DatasetError(f"{root}/manifest.json holds no valid set spec ({type(exc).__name__}: "
                               f"{str(exc)[:120]}); run `ndrql data generate` into a new folder") from None
        shard_size = int(manifest["shard_size"])
        parts: dict[str, list[np.ndarray]] = {}
        for k in range(n_shards(spec.count, shard_size)):
            for key, arr in read_shard(root, k, spec.count, shard_size, bool(spec.masks)).items():
                parts.setdefault(key, []).append(arr)

        def offsets(key: str) -> np.ndarray:
            out, base = [np.zeros(1, np.int64)], 0
            for off in parts[key]:
                out.append(off[1:] + base)
                base += int(off[-1])
            return np.concatenate(out)

        return cls(root=root, spec=spec, sizes=np.concatenate(parts["sizes"]), points=np.concatenate(parts["points"]),
                   families=np.concatenate(parts["families"]), map_offsets=offsets("map_offsets"),
                   maps=np.concatenate(parts["maps"]), wp_offsets=offsets("wp_offsets"),
                   waypoints=np.concatenate(parts["waypoints"]),
                   **({key: np.concatenate(parts[key]) for key in BELIEF_KEYS} if spec.masks else {}))

    def __len__(self) -> int:
        return len(self.sizes)

    def obstacles(self, i: int) -> np.ndarray:
        s = int(self.sizes[i])
        packed = self.maps[self.map_offsets[i]:self.map_offsets[i + 1]]
        return np.unpackbits(packed, count=s * s).reshape(s, s).astype(bool)

    def _bits(self, packed: np.ndarray, i: int) -> np.ndarray:
        s = int(self.sizes[i])
        return np.unpackbits(packed[self.map_offsets[i]:self.map_offsets[i + 1]], count=s * s).reshape(s, s).astype(bool)

    def belief(self, i: int) -> Belief | None:
        """The belief stored with sample ``i`` (a set drawn with ``--masks``), else ``None``."""
        if self.mask_kinds is None or self.believed is None or self.unknown is None:
            return None
        code = int(self.mask_kinds[i])
        kind = KIND_CODES[code] if 0 < code < len(KIND_CODES) else "known"
        return Belief(self._bits(self.believed, i), self._bits(self.unknown, i), kind=kind)

    def raw(self, i: int) -> RawSample:
        sr, sc, gr, gc = (int(v) for v in self.points[i])
        wp = self.waypoints[self.wp_offsets[i]:self.wp_offsets[i + 1]]
        return RawSample(self.obstacles(i), (sr, sc), (gr, gc), np.asarray(wp), str(self.families[i]))
