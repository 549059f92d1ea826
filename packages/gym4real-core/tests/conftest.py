from __future__ import annotations

import os

os.environ.setdefault("GYM4REAL_OFFLINE", "1")
