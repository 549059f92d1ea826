"""Downloads of registered data files from a local HTTP server: deadline, leftovers, corrupt cache copies.

The server runs on 127.0.0.1 in the test: ``/good.csv`` is the registered file, ``/trickle.csv`` sends
one byte every 50 ms (at most TRICKLE_BYTES bytes, then it hangs up by itself), anything else is 404.
"""

from __future__ import annotations

import hashlib
import http.server
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from gym4real.core import datasets
from gym4real.core.errors import DataFileError
from gym4real.core.registry import Registry
from gym4real.core.specs import DatasetSpec

CONTENT = b"year,level\n1990,1.25\n1991,0.75\n"
SHA = hashlib.sha256(CONTENT).hexdigest()
#: A trickling response ends after this many bytes (50 ms apart: 10 s), so the server always stops.
TRICKLE_BYTES = 200
PATH = "demo/level/file.csv"


class Upstream(http.server.BaseHTTPRequestHandler):
    def do_GET(self) -> None:
        if self.path == "/good.csv":
            self.send_response(200)
            self.send_header("Content-Length", str(len(CONTENT)))
            self.end_headers()
            self.wfile.write(CONTENT)
        elif self.path == "/trickle.csv":
            self.send_response(200)
            self.send_header("Content-Length", str(100 * TRICKLE_BYTES))
            self.end_headers()
            try:
                for _ in range(TRICKLE_BYTES):
                    self.wfile.write(b"x")
                    self.wfile.flush()
                    time.sleep(0.05)
            except OSError:  # the client hung up
                pass
        else:
            self.send_error(404)

    def log_message(self, *args: object) -> None:
        pass


@pytest.fixture
def server() -> Iterator[str]:
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Upstream)
    thread = threading.Thread(target=httpd.serve_forever, args=(0.05,), daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()
    httpd.server_close()


@pytest.fixture
def cache(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Path:
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("GYM4REAL_DATA_DIR", raising=False)
    monkeypatch.delenv("GYM4REAL_OFFLINE", raising=False)
    monkeypatch.delenv("GYM4REAL_DOWNLOAD_DEADLINE", raising=False)
    return tmp_path / "cache"


def register(monkeypatch: pytest.MonkeyPatch, url: str) -> None:
    reg = Registry()
    reg.datasets["demo/file"] = DatasetSpec(name="demo/file", path=PATH, sha256=SHA, url=url)
    monkeypatch.setattr(datasets, "registry", lambda: reg)


def leftovers(cache: Path) -> list[str]:
    """Every file and folder in the cache, relative to it."""
    return sorted(str(p.relative_to(cache)) for p in cache.rglob("*")) if cache.exists() else []


def test_a_trickling_server_is_cut_off_at_the_deadline(server, cache, monkeypatch) -> None:
    register(monkeypatch, f"{server}/trickle.csv")
    monkeypatch.setenv("GYM4REAL_DOWNLOAD_DEADLINE", "1")
    start = time.monotonic()
    with pytest.raises(DataFileError) as exc:
        datasets.resolve("demo/file")
    elapsed = time.monotonic() - start
    msg = str(exc.value)
    assert "deadline of 1 s" in msg and "GYM4REAL_DOWNLOAD_DEADLINE" in msg, msg
    # the server would go on for TRICKLE_BYTES * 50 ms = 10 s; the deadline (plus one read of at most 1 s) stops it
    assert elapsed < 5, elapsed
    assert leftovers(cache) == []


def test_the_deadline_defaults_to_five_minutes_and_is_validated(monkeypatch) -> None:
    monkeypatch.delenv("GYM4REAL_DOWNLOAD_DEADLINE", raising=False)
    assert datasets.download_deadline() == 300
    monkeypatch.setenv("GYM4REAL_DOWNLOAD_DEADLINE", "2.5")
    assert datasets.download_deadline() == 2.5
    for bad in ("0", "-3", "inf", "nan", "soon"):
        monkeypatch.setenv("GYM4REAL_DOWNLOAD_DEADLINE", bad)
        with pytest.raises(DataFileError, match="GYM4REAL_DOWNLOAD_DEADLINE must be a positive number"):
            datasets.download_deadline()


@pytest.mark.parametrize("name", ["missing.csv", "trickle.csv"])
def test_a_failed_download_leaves_no_file_and_no_folder(server, cache, monkeypatch, name) -> None:
    register(monkeypatch, f"{server}/{name}")
    monkeypatch.setenv("GYM4REAL_DOWNLOAD_DEADLINE", "0.5")
    with pytest.raises(DataFileError, match="not found"):
        datasets.resolve("demo/file")
    assert leftovers(cache) == []


def test_a_killed_download_leaves_a_temporary_file_that_the_next_download_removes(server, cache, monkeypatch) -> None:
    script = f"""
        from gym4real.core import datasets
        from gym4real.core.registry import Registry
        from gym4real.core.specs import DatasetSpec

        url = {server + "/trickle.csv"!r}
        reg = Registry()
        reg.datasets["demo/file"] = DatasetSpec(name="demo/file", path={PATH!r}, sha256={SHA!r}, url=url)
        datasets.registry = lambda: reg
        datasets.resolve("demo/file")
    """
    child = subprocess.Popen([sys.executable, "-c", textwrap.dedent(script)], env={**os.environ})
    try:
        end = time.monotonic() + 30
        while not any(p.is_file() and p.suffix != ".lock" for p in cache.rglob("*")):
            assert child.poll() is None and time.monotonic() < end, "the download never started"
            time.sleep(0.05)
    finally:
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=30)
    assert any(p.is_file() for p in cache.rglob("*"))  # the killed download left its partial file

    register(monkeypatch, f"{server}/good.csv")
    path = datasets.resolve("demo/file")
    assert path.read_bytes() == CONTENT
    assert leftovers(cache) == ["demo", "demo/level", PATH]


def test_offline_with_a_corrupt_cached_copy_says_corrupt(cache, monkeypatch) -> None:
    register(monkeypatch, "http://127.0.0.1:9/unused.csv")
    copy = cache / PATH
    copy.parent.mkdir(parents=True)
    copy.write_bytes(CONTENT[:-5])
    monkeypatch.setenv("GYM4REAL_OFFLINE", "1")
    with pytest.raises(DataFileError) as exc:
        datasets.resolve("demo/file")
    msg = str(exc.value)
    assert "corrupt" in msg and str(copy) in msg and SHA in msg, msg
    assert "not found" not in msg, msg


def test_online_a_corrupt_cached_copy_is_replaced(server, cache, monkeypatch) -> None:
    register(monkeypatch, f"{server}/good.csv")
    copy = cache / PATH
    copy.parent.mkdir(parents=True)
    copy.write_bytes(CONTENT[:-5])
    assert datasets.resolve("demo/file").read_bytes() == CONTENT
    assert leftovers(cache) == ["demo", "demo/level", PATH]
