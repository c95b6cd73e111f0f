"""Fuzzing the map parsers: random bytes and random valid-looking headers either load or raise
MapFormatError (never another exception type)."""

from __future__ import annotations

import io
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ndrql.errors import MapFormatError
from ndrql.maps import GridMap, load_map, read_movingai_scen

#: Examples per fuzz test: modest by default so the suite stays fast; raise with NDRQL_FUZZ_EXAMPLES.
FUZZ = settings(max_examples=int(os.environ.get("NDRQL_FUZZ_EXAMPLES", "40")), deadline=None, suppress_health_check=[HealthCheck.too_slow])
SUFFIXES = [".png", ".jpg", ".pgm", ".bmp", ".yaml", ".map", ".npy"]


def _load_bytes(data: bytes, suffix: str, extra: dict[str, bytes] | None = None, **kwargs):
    """Write ``data`` to a fresh file with ``suffix`` and load it; return the map or the MapFormatError."""
    with tempfile.TemporaryDirectory() as d:
        for name, content in (extra or {}).items():
            (Path(d) / name).write_bytes(content)
        path = Path(d) / f"fuzz{suffix}"
        path.write_bytes(data)
        try:
            loader = read_movingai_scen if suffix == ".scen" else load_map
            result = loader(path, **kwargs)
        except MapFormatError as exc:
            assert str(exc) and "\n" not in str(exc)
            return exc
    if suffix != ".scen":
        assert isinstance(result, GridMap) and result.obstacles.dtype == bool and result.obstacles.ndim == 2
    return result


@FUZZ
@given(st.binary(max_size=512), st.sampled_from(SUFFIXES + [".scen"]))
def test_random_bytes(data, suffix):
    _load_bytes(data, suffix)


@FUZZ
@given(
    st.sampled_from(["octile", "OCTILE", "hex", ""]),
    st.one_of(st.integers(-2, 6), st.just(10**9)).map(str) | st.sampled_from(["x", "3.5", ""]),
    st.one_of(st.integers(-2, 6), st.just(10**9)).map(str) | st.sampled_from(["x", "1e3"]),
    st.lists(st.text(alphabet=".@GSOTWx \r\t", max_size=7), max_size=7),
    st.booleans(),
)
def test_movingai_valid_looking_headers(kind, height, width, rows, with_map_line):
    header = f"type {kind}\nheight {height}\nwidth {width}\n" + ("map\n" if with_map_line else "")
    out = _load_bytes((header + "\n".join(rows)).encode(), ".map")
    if isinstance(out, GridMap):
        assert out.shape == (int(height), int(width))


@FUZZ
@given(
    st.sampled_from(["version 1", "version 1.0", "version x", ""]),
    st.lists(
        st.lists(st.one_of(st.integers(-3, 12).map(str), st.sampled_from(["a.map", "x", "1.5", "nan", ""])),
                 min_size=7, max_size=10).map("\t".join),
        max_size=4,
    ),
)
def test_scen_valid_looking_lines(version, lines):
    out = _load_bytes("\n".join([version, *lines]).encode(), ".scen")
    if not isinstance(out, MapFormatError):
        for s in out:
            assert 0 <= s.start[0] < s.height and 0 <= s.start[1] < s.width


@FUZZ
@given(st.sampled_from(["P5", "P2", "P6", "P4"]), st.integers(0, 40), st.integers(0, 40),
       st.sampled_from([1, 255, 65535, 70000]), st.binary(max_size=2000))
def test_pgm_valid_looking_headers(magic, w, h, maxval, body):
    header = f"{magic}\n{w} {h}\n" + ("" if magic == "P4" else f"{maxval}\n")
    _load_bytes(header.encode() + body, ".pgm")


def _png_bytes(seed: int) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.random.default_rng(seed).integers(0, 255, (9, 13), dtype=np.uint8)).save(buf, format="PNG")
    return buf.getvalue()


@FUZZ
@given(st.integers(0, 3), st.lists(st.tuples(st.integers(0, 10**6), st.integers(0, 255)), min_size=1, max_size=6),
       st.integers(8, 400))
def test_corrupted_png(seed, flips, cut):
    data = bytearray(_png_bytes(seed))
    for pos, val in flips:
        data[pos % len(data)] = val
    _load_bytes(bytes(data[:cut]), ".png")


@FUZZ
@given(
    st.sampled_from(["|b1", "<f4", "<i8", "|u1", "<c8", "|O", "<U3", "<f8"]),
    st.lists(st.integers(0, 5), max_size=3),
    st.booleans(),
    st.binary(max_size=200),
)
def test_npy_valid_looking_headers(descr, shape, fortran, body):
    header = repr({"descr": descr, "fortran_order": fortran, "shape": tuple(shape)}).encode()
    header += b" " * (-(len(header) + 11) % 64) + b"\n"
    data = b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header + body
    _load_bytes(data, ".npy")


_YAML_VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-5, 5), st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(["m.pgm", "missing.pgm", "trinary", "scale", "raw", "", "[1, 2"]),
    st.lists(st.one_of(st.floats(-5, 5), st.text(max_size=3)), max_size=4),
)


@FUZZ
@given(
    st.dictionaries(
        st.sampled_from(["image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"]),
        _YAML_VALUES,
        max_size=7,
    ),
    st.booleans(),
)
def test_ros_yaml_valid_looking(doc, crop):
    import yaml
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.array([[0, 205, 254], [254, 254, 0]], dtype=np.uint8)).save(buf, format="PPM")
    text = yaml.safe_dump(doc, default_flow_style=True)
    _load_bytes(text.encode(), ".yaml", extra={"m.pgm": buf.getvalue()}, crop=crop)


def test_a_valid_ros_map_does_load_in_the_fuzz_harness():
    import yaml
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.array([[0, 205, 254]], dtype=np.uint8)).save(buf, format="PPM")
    doc = {"image": "m.pgm", "resolution": 0.1, "origin": [0, 0, 0], "occupied_thresh": 0.65, "free_thresh": 0.196}
    out = _load_bytes(yaml.safe_dump(doc).encode(), ".yaml", extra={"m.pgm": buf.getvalue()})
    assert isinstance(out, GridMap) and out.obstacles.tolist() == [[True, True, False]]


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_empty_file_is_a_map_format_error(suffix):
    assert isinstance(_load_bytes(b"", suffix), MapFormatError)
