"""Property-based fuzz of the readers' pixel rule, the point parsers, request validation, the output
guard and the batch log: each either gives the right answer or one of ndrql's own errors, never
another exception. Small by default (a few seconds); raise ``NDRQL_FUZZ_EXAMPLES`` for a longer run.
"""

from __future__ import annotations

import math
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from PIL import Image

from ndrql.cli.common import parse_point
from ndrql.errors import MapFormatError, NdrqlError, OutputError
from ndrql.io.guard import Input, Output, check_outputs
from ndrql.io.jsonl import BatchLog
from ndrql.io.text import load_json, load_yaml
from ndrql.limits import check_cell
from ndrql.maps import load_map
from ndrql.maps.world import parse_world_point
from ndrql.pipeline.settings import PlanSettings
from ndrql.planning.config import PriorConfig, QLConfig

FUZZ = settings(max_examples=int(os.environ.get("NDRQL_FUZZ_EXAMPLES", "30")), deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


# --- one meaning per pixel ---------------------------------------------------------------------------


@FUZZ
@given(hnp.arrays(np.uint16, st.tuples(st.integers(1, 6), st.integers(1, 6))))
def test_a_16_bit_pixel_is_read_by_its_own_value(arr):
    with tempfile.TemporaryDirectory() as d:
        Image.fromarray(arr).save(Path(d) / "m.png")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "all values <= 255" is warned about, by design
            got = load_map(Path(d) / "m.png").obstacles
    assert np.array_equal(got, arr.astype(np.float64) * (255.0 / 65535.0) < 128)


@FUZZ
@given(hnp.arrays(np.float32, st.tuples(st.integers(1, 5), st.integers(1, 5)),
                  elements=st.one_of(st.floats(-0.5, 1.5, width=32), st.sampled_from([math.nan, math.inf, -math.inf]))))
def test_a_float_pixel_is_on_0_to_1_and_nan_is_refused(arr):
    with tempfile.TemporaryDirectory() as d:
        Image.fromarray(arr).save(Path(d) / "m.tiff")
        if not np.isfinite(arr).all() or arr.min() < 0 or arr.max() > 1:
            with pytest.raises(MapFormatError):
                load_map(Path(d) / "m.tiff")
            return
        got = load_map(Path(d) / "m.tiff").obstacles
    assert np.array_equal(got, arr.astype(np.float64) * 255.0 < 128)


# --- point parsers ----------------------------------------------------------------------------------


@FUZZ
@given(st.one_of(st.text(max_size=40), st.tuples(st.integers(-10**15, 10**15), st.integers(-10**15, 10**15)).map(
    lambda t: f"{t[0]}, {t[1]}")))
def test_parse_point(text):
    try:
        r, c = parse_point(text, "--start")
    except NdrqlError:
        return
    head, tail = text.split(",")
    assert (r, c) == (int(head), int(tail))


@FUZZ
@given(st.text(max_size=60))
def test_parse_world_point(text):
    try:
        x, y, yaw = parse_world_point(text, "--start-world")
    except NdrqlError:
        return
    assert all(math.isfinite(v) for v in (x, y) + ((yaw,) if yaw is not None else ()))


@FUZZ
@given(st.one_of(st.none(), st.text(max_size=5), st.lists(st.one_of(st.integers(), st.floats(), st.booleans(),
                                                                    st.text(max_size=2)), max_size=4)))
def test_check_cell(value):
    try:
        r, c = check_cell(value, "start")
    except ValueError:
        return
    assert [r, c] == [int(v) for v in value] and all(float(v) == int(v) for v in value)


# --- request validation -----------------------------------------------------------------------------

NUMBERS = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**12, 10**12), st.booleans())


QL_FIELDS = ("alpha", "epsilon", "gamma", "reward_goal", "reward_collision", "reward_revisit", "max_episodes", "window",
             "max_steps")
PRIOR_FIELDS = ("r0", "r_max", "g_row", "omega_qi", "mask_low", "thd_step", "region_dilation")


@FUZZ
@given(st.sampled_from([QLConfig, PriorConfig]).flatmap(lambda cls: st.tuples(st.just(cls), st.fixed_dictionaries(
    {}, optional={k: NUMBERS for k in (QL_FIELDS if cls is QLConfig else PRIOR_FIELDS)}))))
def test_configs_accept_only_finite_bounded_values(case):
    cls, kw = case
    try:
        cfg = cls(**kw)
    except ValueError:
        return
    for name, value in kw.items():
        got = getattr(cfg, name)
        assert got is None or (math.isfinite(got) and abs(got) <= (1e9 if name in ("max_episodes", "window",
                                                                                 "max_steps") else 1e6))
        assert not isinstance(value, bool)


@FUZZ
@given(st.fixed_dictionaries({}, optional={"size": st.one_of(st.integers(-5, 5000), st.text(max_size=6)),
                                           "threads": st.integers(-3, 10**7), "robot_radius": NUMBERS,
                                           "max_size": st.integers(-3, 5000), "grid": st.sampled_from(["safe", "area", "x"])}))
def test_plan_settings_validate_or_refuse(kw):
    try:
        s = PlanSettings(**kw)
    except (NdrqlError, ValueError):
        return
    assert 1 <= s.threads <= (os.cpu_count() or 1) and 2 <= s.max_size <= 1024


# --- text inputs -------------------------------------------------------------------------------------


@FUZZ
@given(st.text(max_size=200))
def test_yaml_and_json_loaders_parse_or_refuse(text):
    for load in (load_yaml, load_json):
        try:
            load(text, "input")
        except NdrqlError:
            pass


# --- the output guard and the batch log ---------------------------------------------------------------

NAMES = ["a.png", "b.json", "link.png", "sub/../a.png", "sub/c.png", "hard.png", "new.json", "sub"]


@pytest.fixture(scope="module")
def tree(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("guard")
    (root / "a.png").write_bytes(b"a")
    (root / "b.json").write_text("{}")
    (root / "sub").mkdir()
    (root / "sub" / "c.png").write_bytes(b"c")
    (root / "link.png").symlink_to("a.png")
    os.link(root / "a.png", root / "hard.png")
    return root


def _same(root: Path, a: str, b: str) -> bool:
    pa, pb = root / a, root / b
    if os.path.realpath(pa) == os.path.realpath(pb):
        return True
    return pa.exists() and pb.exists() and os.path.samefile(pa, pb)


@FUZZ
@given(outs=st.lists(st.sampled_from(NAMES), min_size=1, max_size=3), ins=st.lists(st.sampled_from(NAMES), max_size=3))
def test_the_guard_refuses_exactly_the_clashes(tree, outs, ins):
    assume("sub" not in outs)  # a folder in the way is check_writable's concern
    outputs = [Output(f"--o{i}", str(tree / o)) for i, o in enumerate(outs)]
    inputs = [Input(f"--i{i}", str(tree / n)) for i, n in enumerate(ins) if (tree / n).is_file()]
    clash = any(_same(tree, o, i.path) for o in outs for i in inputs) or \
        any(_same(tree, a, b) for k, a in enumerate(outs) for b in outs[k + 1:]) or \
        any((tree / o).is_symlink() for o in outs)  # the writer never writes through a symlink
    try:
        check_outputs(outputs, inputs)
    except OutputError:
        assert clash
        return
    assert not clash


@FUZZ
@given(st.binary(max_size=300))
def test_the_batch_log_resumes_only_its_own_files(data):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "log.jsonl"
        path.write_bytes(data)
        try:
            with BatchLog(path, "fmt/1", {"map": "m"}, "scenario") as log:
                done = log.done
        except NdrqlError:
            assert path.read_bytes() == data  # refused: untouched
            return
        assert data.strip() == b"" or done or data.startswith(b'{"format": "fmt/1"')
