"""The prediction cache keeps a grid-mode model's values per cell as they are when its view merges or shrinks
cells (mode ``cells``); the numbers are those of the 4 px drawing it stored before (mode ``grid``), bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.dataset.render import grid_cells_to_map, to_map_pixels
from ndrql.maps.safe import grid_shape
from ndrql.model.predict import _drawn
from ndrql.pipeline.samples import _per_cell


@pytest.mark.parametrize("shape", [(37, 37), (50, 50), (64, 48), (150, 150), (256, 256)])
def test_cells_entries_give_the_numbers_of_drawn_entries(shape):
    """Float16 probabilities and float32 distances per cell: the 4x4 means of their drawing (what an entry
    stored before) are the values themselves, on the planning grid and on the map's pixels."""
    rng = np.random.default_rng(sum(shape))
    side = 4 * max(shape)
    values = {np.float16: rng.random(shape), np.float32: rng.random(shape) * 4 * max(shape)}
    for dtype, cells in values.items():
        drawn = _drawn(cells, side).astype(dtype).astype(np.float32)  # as the cache stored and read them
        kept = cells.astype(dtype).astype(np.float32)
        assert np.array_equal(_per_cell("grid", drawn, shape), _per_cell("cells", kept, shape))
        for map_shape in ((int(shape[0] * 3.3), int(shape[1] * 3.3)), (4 * shape[0] + 1, 4 * shape[1] - 3)):
            n = max(shape)
            fitted = _per_cell("cells", kept, grid_shape(map_shape, n))
            assert np.array_equal(to_map_pixels(drawn, map_shape, n), grid_cells_to_map(fitted, map_shape, n))
