from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
os.environ.setdefault("GYM4REAL_DATA_DIR", str(ROOT.parent / "shared" / "data"))
os.environ.setdefault("GYM4REAL_OFFLINE", "1")
