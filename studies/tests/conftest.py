"""The studies import each other by bare name, as when run from ``studies/``: put it on the path."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
