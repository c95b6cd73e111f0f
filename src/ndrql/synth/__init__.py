"""The map engine: procedural map families at any size, for training the NDR model on unlimited maps.

``generate_map("maze", np.random.default_rng(0), 401, 401)`` draws one boolean obstacle map
(``True`` = obstacle); :data:`FAMILIES` lists the families. Low layer: imports numpy, scipy and
:mod:`ndrql.errors` only.
"""

from ndrql.synth.families import FAMILIES, Family, family_names, generate_map

__all__ = ["FAMILIES", "Family", "family_names", "generate_map"]
