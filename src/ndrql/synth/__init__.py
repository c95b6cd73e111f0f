"""The map engine: procedural map families at any size, for training the NDR model on unlimited maps.

``generate_map("maze", np.random.default_rng(0), 401, 401)`` draws one boolean obstacle map
(``True`` = obstacle); :data:`FAMILIES` lists the families. Low layer: imports numpy, scipy and
:mod:`ndrql.errors` only.

The labels come with it: :func:`make_labels` draws the dataset's guideline and region of a path
(:mod:`ndrql.synth.labels`), :func:`sample_endpoints` draws start/goal pairs like the dataset's
(:mod:`ndrql.synth.endpoints`), :func:`oracle_prediction` draws the labels of a planning grid's own
path (:mod:`ndrql.synth.oracle`). These search and draw with :mod:`ndrql.maps` (one layer down),
whose numba kernels load on first use. The names below load on first use as well.
"""

from __future__ import annotations

from ndrql._lazy import lazy_getattr

#: Public names and the module each lives in; they load on first use, so that a module that needs
#: only the labels (:mod:`ndrql.synth.labels`, numpy) does not pay for the map engine (scipy).
_EXPORTS = {
    "sample_endpoints": "endpoints",
    "FAMILIES": "families", "Family": "families", "family_names": "families", "generate_map": "families",
    "GUIDE_PX": "labels", "REGION_PX": "labels", "Labels": "labels", "dilate_region": "labels",
    "draw_guideline": "labels", "make_labels": "labels", "near_optimal_path": "labels",
    "oracle_prediction": "oracle",
}

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_getattr("ndrql.synth", _EXPORTS, globals())
