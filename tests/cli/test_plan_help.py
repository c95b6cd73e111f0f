"""``plan --help`` says what a plain run uses (issue 55): every default it prints is checked against the request
a plain ``ndrql plan MAP --start ... --goal ...`` builds, and the flags come in groups a user scans."""

from __future__ import annotations

import re

import numpy as np
import pytest
from PIL import Image

from ndrql.cli import main
from ndrql.cli.plan_help import number
from ndrql.pipeline.request import PRIOR_FIELDS, QL_FIELDS, build_request


@pytest.fixture
def help_text(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "2000")  # one line per flag
    monkeypatch.delenv("NDRQL_WEIGHTS", raising=False)
    with pytest.raises(SystemExit) as done:
        main(["plan", "--help"])
    assert done.value.code == 0
    return capsys.readouterr().out


@pytest.fixture
def plain(tmp_path, monkeypatch):
    """The request of a plain run on a map file (nothing but the map and the points)."""
    monkeypatch.delenv("NDRQL_WEIGHTS", raising=False)
    Image.fromarray(np.full((60, 60), 255, np.uint8)).save(tmp_path / "m.png")
    return build_request(tmp_path / "m.png", (2, 2), (50, 50))


def shown(help_text: str, flag: str) -> str:
    """The ``(default: ...)`` text of ``flag``'s help line."""
    lines = help_text.splitlines()
    k = next(i for i, x in enumerate(lines) if re.match(rf"^\s+{re.escape(flag)}([ ,]|$)", x))
    line = lines[k] if "(default: " in lines[k] else lines[k + 1]  # a long flag has its help on the next line
    found = re.search(r"\(default: (.*)\)\s*$", line)
    assert found, line
    return found.group(1)


def test_constant_defaults_are_the_presets_a_plain_run_uses(help_text, plain):
    preset = plain.preset
    sizes = sorted(preset.grids) or [None]
    for name in QL_FIELDS + PRIOR_FIELDS:
        text = shown(help_text, "--" + name.replace("_", "-"))

        def ran(n: int | None) -> str:
            ql, pri = plain.constants(plain.methods[0], n)
            value = getattr(ql, name) if hasattr(ql, name) else getattr(pri, name)
            return "4 x cells" if value is None else number(value)

        if "by grid size" in text:
            assert f"preset {preset.name}'s for {plain.methods[0]}" in text
            pairs = re.findall(r"(\S+) at ([\d/]+)", text.split(": ", 1)[1])
            listed = [int(n) for _, ns in pairs for n in ns.split("/")]
            assert listed == sizes, (name, text)
            for value, ns in pairs:
                for n in ns.split("/"):
                    assert value == ran(int(n)), (name, n, text)
        else:
            value = text.split(",")[0]
            assert all(value == ran(n) for n in sizes), (name, text, [ran(n) for n in sizes])


def test_other_defaults_are_what_a_plain_run_decides(help_text, plain):
    s = plain.settings
    assert shown(help_text, "--method") == plain.methods[0] == "NDR-QL"
    assert shown(help_text, "--grid").startswith(f"{s.grid} for a map file")
    assert shown(help_text, "--size").startswith(f"{s.grid_size} for safe")
    assert shown(help_text, "--max-size") == str(s.max_size)
    assert shown(help_text, "--robot-radius") == f"{s.robot_radius:g}"
    assert shown(help_text, "--smooth").startswith("on for a map file") and s.smoothing
    assert shown(help_text, "--fallback").startswith(f"{s.fallback} for a map file with one method")
    assert shown(help_text, "--max-pixels") == f"{s.max_map_pixels:,}"
    assert shown(help_text, "--threads") == str(s.threads) and shown(help_text, "--backend") == s.backend
    assert shown(help_text, "--symmetries") == str(s.symmetries)
    assert f"the one searched for --weights: {plain.preset.name} for the default weights" in shown(help_text, "--preset")


def test_flags_come_in_groups(help_text):
    groups = [x.rstrip(":") for x in help_text.splitlines() if x and not x.startswith(" ") and x.endswith(":")]
    heads = [g.split(":")[0].split(" (")[0] for g in groups]
    for want in ("input", "method", "output", "ROS maps", "batch", "advanced"):
        assert any(h.startswith(want) for h in heads), heads
    assert len(groups) >= 8  # no catch-all first group
