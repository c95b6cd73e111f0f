"""Shared fixtures: the real dataset (skipped when absent), the console script, the model weights, a tiny dataset.

Shared functions live in ``tests/helpers`` (``helpers.cli``: run the console script, check a one-line error).
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import pytest

from helpers import DATASET_DIR
from helpers.synthetic_dataset import make_tiny_dataset


@pytest.fixture(scope="session")
def dataset_root() -> Path:
    """Root of the real path-planning dataset; the test is skipped when it is absent.

    ``$NDRQL_DATASET`` when set, else where ``ndrql`` itself looks (``ndrql.dataset.layout.default_root``:
    a ``path-planning-dataset`` folder in the working directory, or ``../shared/data`` beside the repo).
    """
    from ndrql.dataset.layout import default_root

    root = Path(os.environ.get("NDRQL_DATASET") or default_root() or DATASET_DIR)
    if not (root / "TRAIN").is_dir() or not (root / "TEST" / "SEEN").is_dir():
        pytest.skip(f"dataset not found at {root} (get it: docs/dataset.md; point NDRQL_DATASET at it)")
    return root


@pytest.fixture(scope="session")
def ndrql_exe() -> list[str]:
    """Command prefix that runs the real ``ndrql`` console script of this environment."""
    exe = Path(sys.executable).with_name("ndrql")
    if exe.exists():
        return [str(exe)]
    found = shutil.which("ndrql")
    if found:
        return [found]
    pytest.skip("the ndrql console script is not installed (run `make test`)")


@pytest.fixture(scope="session")
def model_weights() -> Path:
    """The NDR model weights ``ndrql plan`` uses by default; the test is skipped when there are none.

    That is ``$NDRQL_WEIGHTS`` if set, else the shipped default (``general``: ``ndrql/data/ndr_general.pt``).
    """
    from ndrql.model.predict import default_weights_path

    path = default_weights_path()
    if not path.is_file():
        pytest.skip(f"no NDR model weights at {path} (shipped in src/ndrql/data/, or set NDRQL_WEIGHTS)")
    return path


@pytest.fixture(scope="session")
def user_weights(model_weights, tmp_path_factory) -> Path:
    """A checkpoint that is not shipped (the shipped model saved again, so its bytes differ): it has no
    shipped ONNX graph, so the ONNX backend exports it into the cache on first use."""
    from ndrql.model.checkpoint import export_weights

    return export_weights(model_weights, tmp_path_factory.mktemp("user") / "user.pt", extra={"note": "not shipped"})


@pytest.fixture(scope="module")
def tiny_dataset(tmp_path_factory, monkeypatch_module):
    """A 16-sample TRAIN / 4-sample TEST dataset in the original layout, with its own cache dir."""
    root = make_tiny_dataset(tmp_path_factory.mktemp("tiny") / "ds", n_train=16, n_test=4)
    monkeypatch_module.setenv("NDRQL_CACHE", str(tmp_path_factory.mktemp("cache")))
    return root


@pytest.fixture(scope="module")
def monkeypatch_module():
    """A module-scoped ``MonkeyPatch`` (pytest's own fixture is function-scoped)."""
    mp = pytest.MonkeyPatch()
    yield mp
    mp.undo()
