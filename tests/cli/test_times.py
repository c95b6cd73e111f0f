"""Honest times and dependencies (issue 55): writing --png/--path-out/--json is in plan's time line and JSON,
and a torch-only command says it needs torch before anything else. In process through ``main()``."""

from __future__ import annotations

import json
import re
import sys

import numpy as np
import pytest
from PIL import Image

from ndrql.cli import main


def test_plan_time_line_holds_the_outputs(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    img = np.full((60, 80), 254, np.uint8)
    img[:, 40:42] = 0
    img[20:40, 40:42] = 254
    Image.fromarray(img).save(tmp_path / "room.pgm")
    (tmp_path / "room.yaml").write_text("image: room.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
                                        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    code = main(["plan", "room.yaml", "--start", "30,5", "--goal", "30,75", "--method", "QL", "--path-out", "p.yaml",
                 "--json", "p.json"])
    out = capsys.readouterr().out
    assert code == 0
    lines = out.splitlines()
    assert lines[-1].startswith("time (s): ") and re.search(r", output \d+\.\d{3}\)$", lines[-1]), lines[-1]
    assert lines.index("wrote p.yaml") < len(lines) - 1  # the time line comes after what it times
    wall = json.loads((tmp_path / "p.json").read_text())["timings"]["wall"]
    assert wall["output"] >= 0.0  # the path's writing, done before the JSON


@pytest.mark.parametrize("target", ["table2", "table1", "table4"])
def test_reproduce_without_torch_says_torch(monkeypatch, capsys, tmp_path, target):
    monkeypatch.chdir(tmp_path)  # no dataset here: the missing torch is still what is said
    monkeypatch.setitem(sys.modules, "torch", None)  # `import torch` raises ImportError
    assert main(["reproduce", target]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"reproduce {target} needs torch" in err and "dataset" not in err, err
