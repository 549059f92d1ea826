"""``benchmarks/bench_standin.py --command`` reads the command's own progress lines."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest

from gym4real.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_the_command_benchmark_reads_the_seconds_of_each_progress_line(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    load_script: Callable[[Path], ModuleType],
) -> None:
    """It read none of the lines the command prints (`1/370 households (0 %, 6 s)`), and failed on an empty list."""
    pytest.importorskip("richardsonpy")
    pytest.importorskip("numba")
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))  # the script imports its folder's report.py
    bench = load_script(ROOT / "benchmarks" / "bench_standin.py")
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    assert main(["data", "synthesize", "microgrid", "--households", "2"]) == 0
    err = capsys.readouterr().err
    seconds = bench.progress_seconds(err)
    assert len(seconds) == 2  # a line after the first household and one after the last
    assert seconds == sorted(seconds) and len(seconds) == err.count("synthesize microgrid: ")
