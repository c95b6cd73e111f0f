"""ndrql: learning-guided grid path planning (NDR-QL).

Kept light on purpose: importing ``ndrql`` must not import torch or numba, so the CLI starts fast.
"""

__version__ = "0.1.0"
