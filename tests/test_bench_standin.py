"""``benchmarks/bench_standin.py --command`` reads the command's own progress lines."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from gym4real.cli import main
from gym4real.microgrid import standin

ROOT = Path(__file__).resolve().parents[1]


def test_the_command_benchmark_reads_the_seconds_of_each_progress_line(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    load_script: Callable[[Path], ModuleType],
) -> None:
    """It read none of the lines the command prints (`1/370 households (0 %, 6 s)`), and failed on an empty list."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))  # the script imports its folder's report.py
    bench = load_script(ROOT / "benchmarks" / "bench_standin.py")

    def synthesize(out: Path, households: int, jobs: int, progress: Any, **_: object) -> Path:
        for done in range(1, households + 1):
            progress(done, households)
        out.parent.mkdir(parents=True)
        out.write_text("stand-in")
        return out

    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(standin, "check_tools", lambda: None)
    monkeypatch.setattr(standin, "synthesize", synthesize)
    assert main(["data", "synthesize", "microgrid", "--households", "20"]) == 0
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.startswith("synthesize microgrid: ")]
    assert len(lines) == 11  # the first household, then each tenth
    assert bench.progress_seconds(err) == [0.0] * 11  # the fake households take no time
