"""``examples/sb3_ppo.py`` runs end to end with a tiny budget (PPO on both envs, scored against A*)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from helpers import REPO_ROOT

pytest.importorskip("stable_baselines3", reason="the rl extra is not installed: pip install 'ndrql[rl]'")


@pytest.mark.slow
def test_sb3_ppo_example_quick(tmp_path):
    env = {**os.environ, "TMPDIR": str(tmp_path)}
    out = subprocess.run([sys.executable, str(REPO_ROOT / "examples" / "sb3_ppo.py"), "--quick", "--eval-episodes", "3"],
                         capture_output=True, text=True, timeout=600, env=env)
    assert out.returncode == 0, out.stderr[-2000:]
    assert not list(tmp_path.glob("SB3-*"))  # no logger folders left in the temporary directory
    lines = out.stdout.splitlines()
    assert lines[0].split()[:2] == ["env", "steps"]
    rows = {line.split(" (")[0]: line.split() for line in lines[1:3]}
    assert set(rows) == {"GridPath-v0", "GridPathRandom-v0"}
    for cols in rows.values():
        assert cols[-4] == "2,048" and cols[-2].endswith("%")
        assert 0 <= int(cols[-2].rstrip("%")) <= 100
        assert cols[-1] == "nan" or float(cols[-1]) >= 1.0  # never shorter than A*
    assert lines[3].startswith("A* (reference)")
