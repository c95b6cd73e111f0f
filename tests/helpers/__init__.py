"""Code shared by the tests (importable from every test folder: ``pythonpath = ["tests"]`` in pyproject.toml).

``cli``: run an ``ndrql`` command (through ``main()`` in this process when that equals a fresh one, else the console
script in a child), check the one-line error (hand-drawn maps: ``ndrql.synth.drawn``); ``child``: one child process
that runs many commands (under a memory cap);
``synthetic_dataset``: a tiny dataset in the original layout; ``sweep_tasks`` and ``tuning_problems``:
work for the kill-and-resume tests, imported by their child processes too.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: The repository (``tests/helpers/__init__.py`` -> two levels up).
REPO_ROOT = Path(__file__).resolve().parents[2]
#: This folder's parent, ``tests/``: put it on ``sys.path`` (or ``PYTHONPATH``) of a child process that imports helpers.
TESTS_DIR = REPO_ROOT / "tests"
#: The dataset lives beside the repository: ``../shared/data/path-planning-dataset``.
DATASET_DIR = (REPO_ROOT.parent / "shared" / "data" / "path-planning-dataset").resolve()


def two_walls() -> np.ndarray:
    """A 120 x 160 grid with two long walls, offset so that a route from (10, 10) to (110, 150) zigzags."""
    grid = np.zeros((120, 160), dtype=bool)
    grid[40:46, :120] = True
    grid[80:86, 40:] = True
    return grid
