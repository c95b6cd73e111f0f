"""The named Q-learning methods of the paper (Tables 2 and 3) and how their priors are built.

Each name maps to a set of priors (docs/method.md, section 5):

========  ===============================================================================
name      priors
========  ===============================================================================
QL        none: ``r_c = r0 = 0``, Q-table 0
D-C       D-CRF (Eq. 2)
N-C       NDR-CRF (Eq. 3)
D-Q       D-QI (Eq. 5)
N-Q       NDR-QI (Eq. 6 with the adaptive threshold of Eq. 7)
IQL       D-C + D-Q (Low et al.: its distance-based initialisation and continuous reward only)
O-QL      D-Q (see below)
NDR-QL    D-C + N-C (mixed by Eq. 4) + D-Q + N-Q (Eq. 6)
IQL-BFS   IQL with Eq. 5 on the exact BFS distance to the goal (beyond the paper; no model)
IQL-NDR   IQL with Eq. 5 on the prior source's goal distance (beyond the paper; D-Q with the model's distance)
========  ===============================================================================

Composition: rewards use Eq. 4 when both D-C and N-C are on, else Eq. 2 or Eq. 3 alone; the
Q-table uses Eq. 6 when N-Q is on (Eq. 6 already contains the D-QI term, so ``N-Q`` and
``D-Q + N-Q`` coincide), else Eq. 5 with D-Q, else 0. A :class:`Method` with ``qi_mask_only``
(not in the registry: Table 2's ablation row ``N-Q``) takes Eq. 6's mask term alone.

**O-QL** (Zhou et al., "An optimized Q-Learning algorithm for mobile robot local path planning",
Knowledge-Based Systems 286, 111400, 2024). Its public abstract lists four changes: a Q-table
initialisation, a new action-selection policy, a new reward function and an RMSprop-adapted
learning rate. The NDR-QL paper states that O-QL's initialisation is the Euclidean-distance one
(Eq. 5) and that every method in its Table 3 runs with a fixed learning rate 0.1 and fixed
epsilon 0.2, which rules out O-QL's learning-rate and action-selection changes in that
comparison. The formulas of O-QL's reward function were not available from the public sources we
could consult (abstract and index pages only), so ``O-QL`` here is exactly D-Q. It is kept as its
own name so results tables match the paper and a fuller O-QL can replace it without touching callers.

**IQL-BFS** (beyond the paper) is not a learning-guided method but a reference: IQL's rewards and its Eq. 5
Q-table with ``dist`` the exact number of moves to the goal through free cells
(:func:`ndrql.planning.priors.exact_distance`) instead of the straight line. It needs no model and runs a
search over the whole grid; on large grids it takes about as few steps as NDR-QL or fewer
(studies/large_view/history.md#distance-through-the-region), which is why the reports carry it as the row
``IQL (BFS distance)``. It takes IQL's constants from a preset unless the preset has its own entry.

**IQL-NDR** (beyond the paper) is IQL's priors (Eq. 2's D-CRF reward, Eq. 5's D-QI) with Eq. 5's ``dist`` the
prior source's goal distance (``build_priors``'s ``distance``: the network's learned distance, on a belief map
floored at the belief's BFS distance, or the exact source's BFS distance): Table 2's D-C + D-Q with the model's
distance in D-Q. It uses neither region nor guideline, but it needs a prior source, so the prediction stage, the
judge and the fallback treat it as an NDR method (``needs_ndr``). On belief maps it is the most reliable use of the
belief model (studies/partial/variants.py, row "IQL (lower bound)": 0.857x IQL-BFS's steps on the development set,
17 / 133 / 3 clear wins / ties / losses). It takes IQL's constants, as IQL-BFS does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ndrql.errors import NdrqlError
from ndrql.maps.grid import area_downscale
from ndrql.planning import priors as P
from ndrql.planning.config import PriorConfig


@dataclass(frozen=True)
class Method:
    """A named combination of priors."""

    name: str
    """Name as in the paper's tables."""
    d_crf: bool = False
    """Distance-based continuous reward (Eq. 2)."""
    n_crf: bool = False
    """Guideline-based continuous reward (Eq. 3; Eq. 4 together with ``d_crf``)."""
    d_qi: bool = False
    """Distance-based Q-table initialisation (Eq. 5)."""
    n_qi: bool = False
    """Region-based Q-table initialisation (Eqs. 6-7)."""
    qi_mask_only: bool = False
    """With ``n_qi``: Eq. 6's mask term alone, without its distance term (Table 2's lone N-Q row)."""
    exact_distance: bool = False
    """With ``d_qi`` (not ``n_qi``): Eq. 5's ``dist`` is the exact BFS distance to the goal, not the straight line."""
    model_distance: bool = False
    """With ``d_qi`` (not ``n_qi``): Eq. 5's ``dist`` is ``build_priors``'s ``distance`` (the prior source's goal
    distance); the method then needs a prior source (:attr:`needs_ndr`) but neither region nor guideline."""
    constants: str | None = None
    """The method whose preset entry this one takes where a preset has none of its own (``None``: none)."""
    description: str = ""
    """One line for help texts."""

    @property
    def needs_guideline(self) -> bool:
        return self.n_crf

    @property
    def needs_region(self) -> bool:
        return self.n_qi

    @property
    def needs_ndr(self) -> bool:
        """Whether the method needs a prior source's outputs (region, guideline and/or goal distance)."""
        return self.n_crf or self.n_qi or self.model_distance

    @property
    def needs_distance(self) -> bool:
        """Whether the method's Q-table reads the prior source's goal distance (Eq. 6's, or Eq. 5's for IQL-NDR)."""
        return self.n_qi or self.model_distance


#: The methods of the paper, by name (docs/method.md).
METHODS: dict[str, Method] = {
    m.name: m
    for m in (
        Method("QL", description="plain Q-learning, no prior"),
        Method("D-C", d_crf=True, description="distance-based continuous reward (Eq. 2)"),
        Method("N-C", n_crf=True, description="NDR guideline continuous reward (Eq. 3)"),
        Method("D-Q", d_qi=True, description="distance-based Q-table initialisation (Eq. 5)"),
        Method("N-Q", n_qi=True, description="NDR region Q-table initialisation (Eqs. 6-7)"),
        Method("IQL", d_crf=True, d_qi=True, description="IQL priors: D-C + D-Q"),
        Method("O-QL", d_qi=True, description="O-QL as far as public: D-Q (see ndrql.planning.methods)"),
        Method(
            "NDR-QL", d_crf=True, n_crf=True, d_qi=True, n_qi=True, description="D-C + N-C (Eq. 4) + D-Q + N-Q (Eq. 6)"
        ),
        Method("IQL-BFS", d_crf=True, d_qi=True, exact_distance=True, constants="IQL",
               description="IQL with Eq. 5 on the exact BFS distance (beyond the paper; a reference, no model)"),
        Method("IQL-NDR", d_crf=True, d_qi=True, model_distance=True, constants="IQL",
               description="IQL with Eq. 5 on the prior source's goal distance (beyond the paper; D-C + D-Q)"),
    )
}


def method_names() -> tuple[str, ...]:
    return tuple(METHODS)


def get_method(name: str | Method) -> Method:
    """The method called ``name``; an unknown name raises :class:`NdrqlError` listing the valid ones."""
    if isinstance(name, Method):
        return name
    try:
        return METHODS[name]
    except KeyError:
        upper = {k.upper(): v for k, v in METHODS.items()}
        if isinstance(name, str) and name.strip().upper() in upper:
            return upper[name.strip().upper()]
        raise NdrqlError(f"unknown method {name!r}; valid methods: {', '.join(METHODS)}") from None


@dataclass(frozen=True)
class Priors:
    """What a method hands to the kernel: per-cell rewards and the initial Q-table."""

    r_c: np.ndarray
    """(H, W) reward of a plain move into each cell (Eq. 1 scenario 4)."""
    q0: np.ndarray
    """(H * W, 4) initial Q-table."""
    threshold: float | None = None
    """NDR-QI's chosen threshold (``None`` if not used or none connected)."""


def build_priors(
    method: str | Method,
    blocked: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    region: np.ndarray | None = None,
    guideline: np.ndarray | None = None,
    cfg: PriorConfig = PriorConfig(),
    distance: np.ndarray | None = None,
    threshold: float | None = ...,  # type: ignore[assignment]
) -> Priors:
    """Rewards and initial Q-table of ``method`` on a planning grid (module docstring for the rules).

    ``region``/``guideline`` are NDR probabilities at the planning grid's shape; they are required
    only by methods that use them. ``distance`` (cells, the grid's shape): the model's predicted
    distance to the goal, which then replaces the straight line in Eq. 6 (NDR-QI), or in Eq. 5 for a method with
    ``model_distance`` (IQL-NDR; other D-QI methods and the rewards keep the straight line); ``cfg.guideline_ties`` then lets the guideline choose among equally
    distant moves (:func:`ndrql.planning.priors.snapped_distance`). ``threshold``: Eq. 7's threshold as the judge
    found it (:func:`ndrql.pipeline.judge.judge`, the same search on the same widened region; ``None``: none joins
    start and goal); left out, NDR-QI searches it itself.
    """
    m = get_method(method)
    blocked = np.asarray(blocked, dtype=bool)
    shape = blocked.shape
    if m.needs_guideline and guideline is None:
        raise NdrqlError(f"method {m.name} needs the NDR guideline prediction (pass --prior-from FILE.npz)")
    if m.needs_region and region is None:
        raise NdrqlError(f"method {m.name} needs the NDR region prediction (pass --prior-from FILE.npz)")
    if m.model_distance and not m.n_qi and distance is None:
        raise NdrqlError(f"{m.name} needs a goal distance from the prior source (weights with a distance head, "
                         f"or --prior-from exact)")
    for name, arr in (("region", region), ("guideline", guideline)):
        if arr is not None and np.shape(arr) != shape:
            raise NdrqlError(
                f"{name} has shape {np.shape(arr)} but the planning grid is {shape}; downscale it with downscale_priors"
            )
    if m.d_crf and m.n_crf:
        r_c = P.mixed_crf(guideline, goal, cfg)  # type: ignore[arg-type]
    elif m.d_crf:
        r_c = P.d_crf(shape, goal, cfg)
    elif m.n_crf:
        r_c = P.ndr_crf(guideline, cfg)  # type: ignore[arg-type]
    else:
        r_c = np.full(shape, cfg.r0, dtype=np.float64)
    thd = None
    if m.n_qi:
        q0, thd = P.ndr_qi(blocked, start, goal, region, cfg, thd=threshold,  # type: ignore[arg-type]
                           mask_only=m.qi_mask_only, distance=distance, guideline=guideline)
    elif m.d_qi:
        dist = distance if m.model_distance else P.exact_distance(blocked, goal) if m.exact_distance else None
        q0 = P.d_qi(blocked, goal, dist)
    else:
        q0 = np.zeros((blocked.size, 4), dtype=np.float64)
    return Priors(r_c=np.ascontiguousarray(r_c, dtype=np.float64), q0=np.ascontiguousarray(q0), threshold=thd)


def downscale_priors(
    region: np.ndarray | None, guideline: np.ndarray | None, shape: tuple[int, int]
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Region and guideline at the map's resolution -> planning grid, by area averaging (docs/method.md)."""
    out = []
    for name, arr in (("region", region), ("guideline", guideline)):
        if arr is None:
            out.append(None)
            continue
        a = np.asarray(arr, dtype=np.float64)
        if a.ndim != 2:
            raise NdrqlError(f"{name} must be a 2-D array of probabilities, got shape {a.shape}")
        if not np.all(np.isfinite(a)) or a.min() < 0.0 or a.max() > 1.0:
            raise NdrqlError(f"{name} must hold probabilities in [0, 1]")
        out.append(a if a.shape == tuple(shape) else area_downscale(a, tuple(shape)))
    return out[0], out[1]


def load_prior_file(path: str) -> tuple[np.ndarray, np.ndarray]:
    """Read ``region`` and ``guideline`` arrays from an ``.npz`` file (map resolution)."""
    import zipfile

    try:
        with np.load(path, allow_pickle=False) as data:
            missing = [k for k in ("region", "guideline") if k not in data.files]
            if missing:
                raise NdrqlError(f"{path}: missing array(s) {', '.join(missing)}; the file needs 'region' and 'guideline'")
            return np.asarray(data["region"], dtype=np.float64), np.asarray(data["guideline"], dtype=np.float64)
    except FileNotFoundError:
        raise NdrqlError(f"prior file not found: {path}") from None
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        reason = str(exc).splitlines()[0][:200] if str(exc) else type(exc).__name__
        if "pickle" in reason.lower():  # numpy's advice to load it unsafely is not repeated
            reason = "not an .npz of plain arrays (reading it would need unpickling, which ndrql refuses)"
        raise NdrqlError(f"cannot read prior file {path}: {reason}") from None
