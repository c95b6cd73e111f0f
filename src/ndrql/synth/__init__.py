"""The map engine: procedural map families at any size, for training the NDR model on unlimited maps.

``generate_map("maze", np.random.default_rng(0), 401, 401)`` draws one boolean obstacle map
(``True`` = obstacle); :data:`FAMILIES` lists the families. Low layer: imports numpy, scipy and
:mod:`ndrql.errors` only.

The labels come with it: :func:`make_labels` draws the dataset's guideline and region of a path
(:mod:`ndrql.synth.labels`), :func:`sample_endpoints` draws start/goal pairs like the dataset's
(:mod:`ndrql.synth.endpoints`), :func:`oracle_prediction` draws the labels of a planning grid's own
path (:mod:`ndrql.synth.oracle`). These search and draw with :mod:`ndrql.maps` (one layer down),
whose numba kernels load on first use.
"""

from ndrql.synth.endpoints import sample_endpoints
from ndrql.synth.families import FAMILIES, Family, family_names, generate_map
from ndrql.synth.labels import (GUIDE_PX, REGION_PX, Labels, dilate_region, draw_guideline, make_labels,
                                near_optimal_path)
from ndrql.synth.oracle import oracle_prediction

__all__ = ["FAMILIES", "Family", "family_names", "generate_map",
           "GUIDE_PX", "REGION_PX", "Labels", "dilate_region", "draw_guideline", "make_labels", "near_optimal_path",
           "sample_endpoints", "oracle_prediction"]
