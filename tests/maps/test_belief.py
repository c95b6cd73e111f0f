"""The belief map type, a mask read from a file, and the checks a planner needs (ndrql.maps.belief)."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from ndrql.errors import MapFormatError, PointError
from ndrql.maps.belief import Belief, check_belief, hidden, known, read_mask


def _map() -> np.ndarray:
    o = np.zeros((10, 12), dtype=bool)
    o[4, 2:10] = True
    return o


def test_belief_clears_obstacles_on_unknown_pixels_and_counts_them():
    o = _map()
    unk = np.zeros_like(o)
    unk[3:6, 5:8] = True
    b = hidden(o, unk)
    assert not b.obstacles[4, 5:8].any() and b.obstacles[4, 2]
    assert (b.planner_obstacles("obstacle") == (o | unk)).all()
    assert (b.planner_obstacles("free") == (o & ~unk)).all()
    assert b.unknown_share(o) == pytest.approx(6 / (~o).sum())
    assert known(o).unknown_share(o) == 0.0
    with pytest.raises(ValueError):
        b.planner_obstacles("maybe")
    with pytest.raises(ValueError):
        Belief(o, unk[:5])


def test_read_mask_from_npy_image_and_array(tmp_path):
    m = np.zeros((10, 12), dtype=np.uint8)
    m[1:3, 1:4] = 7
    np.save(tmp_path / "m.npy", m)
    Image.fromarray(m * 30).save(tmp_path / "m.png")
    for src in (tmp_path / "m.npy", str(tmp_path / "m.png"), m):
        got = read_mask(src, (10, 12))
        assert got.dtype == bool and got.sum() == 6 and got[1, 1]


def test_read_mask_refuses_wrong_size_and_what_is_not_a_mask(tmp_path):
    np.save(tmp_path / "small.npy", np.zeros((9, 12)))
    with pytest.raises(MapFormatError, match="is 9x12 .* the map is 10x12"):
        read_mask(tmp_path / "small.npy", (10, 12))
    (tmp_path / "bad.npy").write_text("not an array")
    with pytest.raises(MapFormatError, match="is not a mask"):
        read_mask(tmp_path / "bad.npy", (10, 12))
    (tmp_path / "bad.png").write_bytes(b"\x89PNG broken")
    with pytest.raises(MapFormatError, match="is not a mask"):
        read_mask(tmp_path / "bad.png", (10, 12))
    np.save(tmp_path / "cube.npy", np.zeros((10, 12, 2)))
    with pytest.raises(MapFormatError, match="2-D"):
        read_mask(tmp_path / "cube.npy", (10, 12))
    (tmp_path / "m.txt").write_text("0 1")
    with pytest.raises(MapFormatError, match="a mask is a .npy array or an image"):
        read_mask(tmp_path / "m.txt", (10, 12))
    with pytest.raises(MapFormatError, match="no such file"):
        read_mask(tmp_path / "nothing.npy", (10, 12))


def test_check_belief_refuses_unknown_points_and_a_mask_that_hides_everything():
    o = _map()
    unk = np.zeros_like(o)
    unk[0, 0] = True
    with pytest.raises(PointError, match="start 0,0 is unknown"):
        check_belief(hidden(o, unk), (0, 0), (9, 11))
    with pytest.raises(PointError, match="goal 0,0 is unknown"):
        check_belief(hidden(o, unk), (9, 11), (0, 0))
    everything = ~o
    everything[0, 0] = everything[9, 11] = False
    with pytest.raises(MapFormatError, match="hides every free pixel"):
        check_belief(hidden(o, everything), (0, 0), (9, 11))
    check_belief(hidden(o, unk), (9, 0), (9, 11))  # a mask that leaves something known passes
