"""What a new user meets first: the README (quickstart, runnable API example, links), docs/cli.md
in sync with the CLI, ``ndrql demo``'s outputs, and a light ``import ndrql``."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest
from PIL import Image

from helpers import REPO_ROOT
from helpers.cli import run_cli
from ndrql.version import PROJECT_URL

README = (REPO_ROOT / "README.md").read_text(encoding="utf-8")


def readme_block(tag: str) -> str:
    """The fenced code block that follows ``<!-- readme-example: TAG ... -->`` in the README."""
    m = re.search(rf"<!-- readme-example: {re.escape(tag)}\b[^>]*-->\s*```\w*\n(.*?)```", README, re.S)
    assert m, f"no README example tagged {tag!r}"
    return m.group(1)


def test_readme_starts_with_the_two_commands():
    first = re.search(r"```\n(.*?)```", README, re.S)
    assert first and first.group(1).split("\n")[:2] == ["make demo", "make test"]
    assert README.index(first.group(0)) < README.index("## ")  # before any section


def test_readme_links_and_picture():
    # absolute addresses: the README is also the package's description on the index, where a link
    # relative to the repository leads nowhere
    for target in ("docs/results.md", "docs/performance.md", "docs/cli.md"):
        assert f"]({PROJECT_URL}/blob/main/{target})" in README, target
    assert f"]({PROJECT_URL.replace('github.com', 'raw.githubusercontent.com')}/main/docs/demo.png)" in README
    for target in ("docs/performance.md", "docs/cli.md", "docs/demo.png"):
        assert (REPO_ROOT / target).is_file(), target
    relative = [t for t in re.findall(r"\]\(([^)\s]+)\)", README) if not re.match(r"[a-z]+://", t)]
    assert not relative, f"links relative to the repository: {relative}"
    for page in re.findall(rf"\]\({re.escape(PROJECT_URL)}/blob/main/([^)#\s]+)", README):
        assert (REPO_ROOT / page).exists(), f"the README links to {page}, which the repository lacks"
    with Image.open(REPO_ROOT / "docs" / "demo.png") as im:
        assert im.format == "PNG"
    assert (REPO_ROOT / "docs" / "demo.png").stat().st_size < 300_000
    for name in ("QL", "D-C", "N-C", "D-Q", "N-Q", "IQL", "O-QL", "NDR-QL"):
        assert re.search(rf"^\| `{re.escape(name)}` \| .*Eq", README, re.M), f"method {name} without its equation"
    for fmt in ("ROS `map_server`", "MovingAI", "--sample", "NumPy", "an image"):
        assert fmt in README


def test_readme_api_example_runs(model_weights, tmp_path):
    code = readme_block("api")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    converged, steps, length, optimum = lines[0].split()
    assert converged == "True" and int(steps) > 0 and int(length) >= int(optimum) > 0
    assert [line.split()[0] for line in lines[1:4]] == ["QL", "IQL", "NDR-QL"]
    assert "'learn'" in lines[4] and "'predict'" in lines[4]


def test_cli_md_in_sync_with_help():
    r = subprocess.run([sys.executable, str(REPO_ROOT / "tools" / "gen_cli_docs.py"), "--check"], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, f"docs/cli.md is stale; run .venv/bin/python tools/gen_cli_docs.py\n{r.stdout}"
    text = (REPO_ROOT / "docs" / "cli.md").read_text(encoding="utf-8")
    for heading in ("### `ndrql plan`", "### `ndrql demo`", "### `ndrql astar`"):
        assert heading in text


def test_import_ndrql_is_light():
    code = ("import sys, ndrql; assert callable(ndrql.__getattr__); "
            "print(sorted(m for m in ('torch', 'numba', 'matplotlib') if m in sys.modules))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.strip() == "[]", (r.stdout, r.stderr)
    code = "import sys, ndrql; ndrql.plan; print('torch' in sys.modules, 'numba' in sys.modules)"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.stdout.strip() == "False False", (r.stdout, r.stderr)  # the API itself loads them only when planning


def test_help_does_not_import_torch_or_numba(ndrql_exe):
    code = ("import sys; from ndrql.cli import build_parser; build_parser().format_help(); "
            "print('torch' in sys.modules, 'numba' in sys.modules)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.stdout.strip() == "False False", (r.stdout, r.stderr)


def test_demo_writes_figures_and_table(ndrql_exe, model_weights, tmp_path):
    out = tmp_path / "demo"
    r = run_cli(ndrql_exe, "demo", "--out", str(out), "--seeds", "3")
    assert r.returncode == 0, r.stderr
    for name in ("compare.png", "ndr-ql.png", "table.md", "results.json"):
        assert (out / name).stat().st_size > 0, name
    assert f"wrote {out / 'compare.png'}" in r.stdout
    table = (out / "table.md").read_text().splitlines()
    rows = [line for line in table if line.startswith("| ") and not line.startswith("| method")]
    assert [row.split("|")[1].strip() for row in rows] == ["QL", "IQL", "NDR-QL"]
    data = json.loads((out / "results.json").read_text())
    assert data["seeds"] == [0, 1, 2] and data["weights"] and data["ndr_qi_threshold"]["NDR-QL"] is not None
    with Image.open(out / "compare.png") as im:
        assert im.size[0] > 2.5 * im.size[1]


def test_model_is_loaded_once_per_process(model_weights):
    import numpy as np

    from ndrql.model.predict import load_predictor
    from ndrql.pipeline.predictions import predict_priors

    a = load_predictor()
    assert load_predictor() is a and load_predictor(model_weights) is a
    obstacles = np.zeros((90, 150), dtype=bool)  # not 201x201: outputs come back at the map's size
    obstacles[30:35, :100] = True
    region, guideline = predict_priors(obstacles, (5, 5), (80, 140))
    assert region.shape == guideline.shape == (90, 150)
    assert 0.0 <= region.min() <= region.max() <= 1.0


@pytest.mark.parametrize("seed", [0, 1])
def test_api_same_seed_same_run(model_weights, seed):
    import numpy as np

    import ndrql

    grid = np.zeros((100, 100), dtype=bool)
    grid[45:50, 20:] = True
    a = ndrql.plan(grid, (5, 5), (95, 95), seed=seed)
    b = ndrql.plan(grid, (5, 5), (95, 95), seed=seed)
    c = ndrql.plan(grid, (5, 5), (95, 95), seed=seed + 7)
    assert a.same_run(b) and a.converged
    assert not a.same_run(c)


def test_api_workers_do_not_change_results(model_weights):
    """In-process runs (priors built once) and the process pool (priors rebuilt per job) make the same runs."""
    import numpy as np

    import ndrql

    grid = np.zeros((120, 90), dtype=bool)
    grid[60:64, 15:] = True
    one = ndrql.solve(grid, (5, 5), (115, 85), ["IQL", "NDR-QL"], seeds=2, workers=1)
    two = ndrql.solve(grid, (5, 5), (115, 85), ["IQL", "NDR-QL"], seeds=2, workers=2)
    assert [r.method for r in one.results] == ["IQL", "IQL", "NDR-QL", "NDR-QL"]
    assert all(a.same_run(b) for a, b in zip(one.results, two.results))
    assert one.thresholds == two.thresholds and set(one.thresholds) == {"NDR-QL"}
    assert one.region.shape == one.guideline.shape == (120, 90)
