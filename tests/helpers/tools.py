"""Importing a script of ``tools/`` (they import each other by bare name, as when run from there)."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path
from types import ModuleType
from typing import Iterator

TOOLS = Path(__file__).resolve().parents[2] / "tools"


def tool_module(name: str) -> Iterator[ModuleType]:
    """Yield ``tools/<name>.py`` as a module, with ``tools/`` on ``sys.path`` only meanwhile (a fixture body)."""
    sys.path.insert(0, str(TOOLS))
    try:
        yield importlib.import_module(name)
    finally:
        sys.path.remove(str(TOOLS))
