"""Test setup: the shared data folder, no downloads."""

from __future__ import annotations

import os
from pathlib import Path

_REPO = Path(__file__).resolve().parents[3]
os.environ.setdefault("GYM4REAL_DATA_DIR", str(_REPO.parent / "shared" / "data"))
os.environ.setdefault("GYM4REAL_OFFLINE", "1")
