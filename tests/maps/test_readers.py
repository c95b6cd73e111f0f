"""Map readers and writers: small fixtures written by the tests, plus the real dataset."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image

from ndrql.errors import MapFormatError
from ndrql.maps import (
    GridMap,
    load_map,
    read_image,
    read_movingai_map,
    read_movingai_scen,
    read_npy,
    read_ros_yaml,
    save_map,
    write_npy,
    write_png,
)

PATTERN = np.array(
    [
        [0, 0, 1, 1, 0],
        [0, 1, 1, 0, 0],
        [0, 0, 0, 0, 1],
    ],
    dtype=bool,
)  # non-square on purpose: 3 rows x 5 cols


def _gray_image(obstacles: np.ndarray, dark: int = 0, light: int = 255) -> np.ndarray:
    return np.where(obstacles, dark, light).astype(np.uint8)


# ------------------------------------------------------------------ plain images


@pytest.mark.parametrize("suffix", [".png", ".pgm", ".bmp", ".jpg"])
def test_read_image_formats_dark_is_obstacle(tmp_path, suffix):
    big = np.kron(PATTERN, np.ones((8, 8), dtype=bool))  # blocks survive JPEG noise
    path = tmp_path / f"m{suffix}"
    Image.fromarray(_gray_image(big)).save(path, **({"quality": 95} if suffix == ".jpg" else {}))
    m = load_map(path)
    assert m.shape == (24, 40)
    np.testing.assert_array_equal(m.obstacles, big)
    assert m.source == str(path)
    np.testing.assert_array_equal(load_map(path, invert=True).obstacles, ~big)


def test_read_image_rgb_and_threshold(tmp_path):
    rgb = np.zeros((3, 5, 3), dtype=np.uint8)
    rgb[~PATTERN] = (255, 255, 255)
    rgb[0, 0] = (120, 130, 140)  # mean 130 -> free at threshold 128
    Image.fromarray(rgb).save(tmp_path / "c.png")
    m = read_image(tmp_path / "c.png")
    np.testing.assert_array_equal(m.obstacles, PATTERN)
    assert read_image(tmp_path / "c.png", threshold=131).obstacles[0, 0]


def test_png_and_npy_round_trip(tmp_path):
    m = GridMap(PATTERN)
    for name in ("m.png", "m.npy"):
        out = save_map(m, tmp_path / name)
        assert load_map(out).obstacles.tolist() == PATTERN.tolist()
    assert not list(tmp_path.glob(".*.tmp"))  # atomic writes leave no temporary files
    with pytest.raises(MapFormatError, match="use .png or .npy"):
        save_map(m, tmp_path / "m.gif")


def test_writers_are_atomic_on_failure(tmp_path):
    target = tmp_path / "keep.npy"
    write_npy(GridMap(PATTERN), target)
    with pytest.raises(ValueError):
        write_npy(np.zeros((2, 2, 2)), target)  # not a map: the old file survives untouched
    np.testing.assert_array_equal(np.load(target), PATTERN)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.npy"]  # no temporary file left
    write_png(GridMap(PATTERN), tmp_path / "nodir" / "m.png")  # missing folders are created
    assert (tmp_path / "nodir" / "m.png").is_file()


def test_npy_reader_rules(tmp_path):
    np.save(tmp_path / "f.npy", PATTERN.astype(np.float32) * 0.7)
    np.testing.assert_array_equal(read_npy(tmp_path / "f.npy").obstacles, PATTERN)
    np.save(tmp_path / "three.npy", np.zeros((2, 2, 2)))
    with pytest.raises(MapFormatError, match="2-D"):
        read_npy(tmp_path / "three.npy")
    np.save(tmp_path / "nan.npy", np.array([[np.nan, 0.0]]))
    with pytest.raises(MapFormatError, match="NaN"):
        read_npy(tmp_path / "nan.npy")
    np.save(tmp_path / "obj.npy", np.array([[None, 1]], dtype=object), allow_pickle=True)
    with pytest.raises(MapFormatError):
        read_npy(tmp_path / "obj.npy")


@pytest.mark.parametrize(
    "name, content, match",
    [
        ("missing.png", None, "not found"),
        ("corrupt.png", b"\x89PNG\r\n\x1a\nthis is not a png", "cannot read image"),
        ("truncated.jpg", None, "cannot read image"),
        ("empty.npy", b"", "cannot read .npy"),
        ("m.txt", b"hello", "unsupported map format"),
        ("noext", b"hello", "unsupported map format"),
    ],
)
def test_bad_files_raise_map_format_error(tmp_path, name, content, match):
    path = tmp_path / name
    if name == "truncated.jpg":
        Image.fromarray(np.random.default_rng(0).integers(0, 255, (64, 64), dtype=np.uint8)).save(path)
        path.write_bytes(path.read_bytes()[:300])
    elif content is not None:
        path.write_bytes(content)
    with pytest.raises(MapFormatError, match=match):
        load_map(path)


# ------------------------------------------------------------------ ROS map_server

ROS_YAML = """image: {image}
resolution: 0.05
origin: [-1.0, -2.0, 0.0]
negate: {negate}
occupied_thresh: 0.65
free_thresh: 0.196
{extra}"""


def _ros_fixture(tmp_path, negate=0, extra="", pixels=None, name="m.pgm"):
    # map_saver values: 254 free, 0 occupied, 205 unknown; unknown border of 1 row/col
    if pixels is None:
        pixels = np.full((5, 7), 205, dtype=np.uint8)
        pixels[1:4, 2:6] = 254
        pixels[2, 3] = 0
    Image.fromarray(pixels).save(tmp_path / name)
    y = tmp_path / "m.yaml"
    y.write_text(ROS_YAML.format(image=name, negate=negate, extra=extra))
    return y


def test_ros_trinary_unknown_is_obstacle(tmp_path):
    m = load_map(_ros_fixture(tmp_path))
    assert m.shape == (5, 7) and m.resolution == 0.05 and m.origin == (-1.0, -2.0, 0.0)
    expected = np.ones((5, 7), dtype=bool)
    expected[1:4, 2:6] = False
    expected[2, 3] = True
    np.testing.assert_array_equal(m.obstacles, expected)


def test_ros_crop_to_known_area_moves_origin(tmp_path):
    m = load_map(_ros_fixture(tmp_path), crop=True)
    assert m.shape == (3, 4)
    assert m.obstacles.sum() == 1 and m.obstacles[1, 1]
    # lower-left known pixel is image row 3, col 2: 2 cols right, 1 row up from the bottom
    assert m.origin == pytest.approx((-1.0 + 2 * 0.05, -2.0 + 1 * 0.05, 0.0))


def test_ros_crop_with_yaw_rotates_the_shift(tmp_path):
    y = _ros_fixture(tmp_path)
    y.write_text(y.read_text().replace("[-1.0, -2.0, 0.0]", f"[0.0, 0.0, {math.pi / 2}]"))
    m = read_ros_yaml(y, crop=True)
    assert m.origin[:2] == pytest.approx((-1 * 0.05, 2 * 0.05))


def test_ros_negate(tmp_path):
    pixels = np.array([[0, 255, 128]], dtype=np.uint8)  # negate: p = v / 255
    m = read_ros_yaml(_ros_fixture(tmp_path, negate=1, pixels=pixels))
    assert m.obstacles.tolist() == [[False, True, True]]  # 128/255 = 0.50: unknown -> obstacle
    m = read_ros_yaml(_ros_fixture(tmp_path, negate=0, pixels=pixels))
    assert m.obstacles.tolist() == [[True, False, True]]


def test_ros_scale_and_raw_modes(tmp_path):
    rgba = np.zeros((1, 4, 4), dtype=np.uint8)
    rgba[0, :, 3] = 255
    rgba[0, 0, :3] = 250  # p 0.02: free
    rgba[0, 1, :3] = 160  # p 0.37: in between, level (0.37-0.196)/0.454 = 0.39 -> free
    rgba[0, 2, :3] = 110  # p 0.57: level 0.83 -> obstacle
    rgba[0, 3, :3] = 160
    rgba[0, 3, 3] = 100  # translucent in-between -> unknown -> obstacle
    m = read_ros_yaml(_ros_fixture(tmp_path, extra="mode: scale\n", pixels=rgba, name="m.png"))
    assert m.obstacles.tolist() == [[False, False, True, True]]
    raw = np.array([[0, 49, 50, 100, 255]], dtype=np.uint8)
    m = read_ros_yaml(_ros_fixture(tmp_path, extra="mode: raw\n", pixels=raw, name="r.png"))
    assert m.obstacles.tolist() == [[False, False, True, True, True]]


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda t: t.replace("resolution: 0.05\n", ""), "missing key.*resolution"),
        (lambda t: t.replace("occupied_thresh: 0.65\n", "").replace("free_thresh: 0.196\n", ""), "occupied_thresh, free_thresh"),
        (lambda t: t.replace("resolution: 0.05", "resolution: fast"), "must be a number"),
        (lambda t: t.replace("resolution: 0.05", "resolution: -1"), "positive"),
        (lambda t: t.replace("[-1.0, -2.0, 0.0]", "here"), "origin"),
        (lambda t: t + "mode: fancy\n", "unknown mode"),
        (lambda t: t.replace("m.pgm", "other.pgm"), "image file not found"),
        (lambda t: "just a string", "mapping"),
        (lambda t: "image: [unclosed", "cannot parse"),
        (lambda t: t.replace("free_thresh: 0.196", "free_thresh: 0.9"), "free_thresh <= occupied_thresh"),
    ],
)
def test_ros_bad_yaml(tmp_path, edit, match):
    y = _ros_fixture(tmp_path)
    y.write_text(edit(y.read_text()))
    with pytest.raises(MapFormatError, match=match):
        load_map(y)


def test_ros_crop_all_unknown(tmp_path):
    y = _ros_fixture(tmp_path, pixels=np.full((3, 3), 205, dtype=np.uint8))
    assert read_ros_yaml(y).obstacles.all()
    with pytest.raises(MapFormatError, match="unknown"):
        read_ros_yaml(y, crop=True)


# ------------------------------------------------------------------ MovingAI

MAP_TEXT = "type octile\nheight 3\nwidth 5\nmap\n..@T.\n.OW..\nGS..@\n"


def test_movingai_map(tmp_path):
    p = tmp_path / "a.map"
    p.write_text(MAP_TEXT)
    m = load_map(p)
    assert m.shape == (3, 5)
    np.testing.assert_array_equal(
        m.obstacles,
        [[0, 0, 1, 1, 0], [0, 1, 1, 0, 0], [0, 0, 0, 0, 1]],
    )
    p.write_text(MAP_TEXT.replace("\n", "\r\n") + "\n\n")  # CRLF and trailing blank lines are fine
    np.testing.assert_array_equal(read_movingai_map(p).obstacles, m.obstacles)


@pytest.mark.parametrize(
    "name, text, match",
    [
        ("b.map", "type octile\nheight 3\nwidth 5\n..@T.\n", "bad header"),
        ("b.map", "type hex\nheight 3\nwidth 5\nmap\n", "only 'octile'"),
        ("b.map", "type octile\nheight three\nwidth 5\nmap\n", "integers"),
        ("b.map", "type octile\nwidth 5\nmap\n.....\n", "missing height"),
        ("b.map", "type octile\nheight 0\nwidth 5\nmap\n", "positive"),
        ("b.map", "type octile\nheight 3\nwidth 5\nmap\n.....\n.....\n", "found 2 rows"),
        ("b.map", "type octile\nheight 2\nwidth 5\nmap\n.....\n....\n", "row 1 has 4 cells"),
        ("b.map", "type octile\nheight 1\nwidth 5\nmap\n..x..\n", "unknown terrain"),
        ("b.map", "hello\n", "bad header"),
        ("b.map", "", "no 'map' line"),
        ("b.scen", "version 1\n0\ta.map\t5\t3\t4\t0\t0\n", "7 fields"),
        ("b.scen", "version 1\n0\ta.map\t5\t3\tx\t0\t0\t2\t1.0\n", "non-numeric"),
        ("b.scen", "version 1\n0\ta.map\t5\t3\t5\t0\t0\t2\t1.0\n", "outside 5x3"),
        ("b.scen", "version one\n", "bad version"),
    ],
)
def test_movingai_bad_files(tmp_path, name, text, match):
    """A broken MovingAI map (read by load_map) or scenario file is one clear MapFormatError."""
    p = tmp_path / name
    p.write_text(text)
    read = read_movingai_scen if name.endswith(".scen") else load_map
    with pytest.raises(MapFormatError, match=match):
        read(p)


def test_movingai_scen_converts_x_y_to_row_col(tmp_path):
    p = tmp_path / "a.map.scen"
    p.write_text("version 1\n0\ta.map\t5\t3\t4\t0\t0\t2\t7.24264069\n1\ta.map\t5\t3\t0\t0\t1\t1\t1.41421356\n")
    scen = read_movingai_scen(p)
    assert len(scen) == 2
    s = scen[0]
    assert (s.bucket, s.map, s.width, s.height) == (0, "a.map", 5, 3)
    assert s.start == (0, 4) and s.goal == (2, 0)  # x = column, y = row
    assert s.optimal_length == pytest.approx(7.24264069)


# ------------------------------------------------------------------ the real dataset


@pytest.mark.data
@pytest.mark.parametrize("split, index", [("TEST/SEEN", 0), ("TRAIN", 5), ("TEST/UNSEEN", 650)])
def test_image_reader_matches_dataset_loader_on_real_maps(dataset_root, split, index):
    from ndrql.dataset.layout import load_sample

    m = load_map(dataset_root / split / "MAP [ORIGINAL]" / f"{index}.jpg")
    short = {"TEST/SEEN": "seen", "TRAIN": "train", "TEST/UNSEEN": "unseen"}[split]
    sample = load_sample(dataset_root, short, index)
    assert m.shape == (201, 201)
    np.testing.assert_array_equal(m.obstacles, sample.map)
    assert 0.02 < m.obstacle_ratio < 0.7


@pytest.mark.data
def test_image_reader_keeps_the_256px_unseen_maps(dataset_root):
    m = load_map(dataset_root / "TEST" / "UNSEEN" / "MAP [ORIGINAL]" / "950.jpg")
    assert m.shape == (256, 256)  # any size is accepted; the dataset loader resizes to 201 like the generator
