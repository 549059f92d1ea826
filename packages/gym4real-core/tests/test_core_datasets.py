from __future__ import annotations

import hashlib
import http.server
import threading
from collections.abc import Iterator
from functools import partial
from pathlib import Path

import pytest

from gym4real.core import datasets
from gym4real.core.errors import DataFileError
from gym4real.core.registry import Registry
from gym4real.core.specs import DatasetSpec

CONTENT = b"year,d1\n1990,1.0\n"
SHA = hashlib.sha256(CONTENT).hexdigest()


@pytest.fixture
def server(tmp_path: Path) -> Iterator[str]:
    root = tmp_path / "upstream"
    root.mkdir()
    (root / "good.csv").write_bytes(CONTENT)
    (root / "bad.csv").write_bytes(CONTENT + b"tampered")
    handler = partial(http.server.SimpleHTTPRequestHandler, directory=str(root))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()


@pytest.fixture
def fake_registry(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> dict[str, DatasetSpec]:
    reg = Registry()
    monkeypatch.setattr(datasets, "registry", lambda: reg)
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("GYM4REAL_DATA_DIR", raising=False)
    monkeypatch.delenv("GYM4REAL_OFFLINE", raising=False)
    return reg.datasets


def add(reg: dict[str, DatasetSpec], url: str, sha: str = SHA) -> DatasetSpec:
    spec = DatasetSpec(name="demo/file", path="demo/sub/file.csv", sha256=sha, url=url)
    reg[spec.name] = spec
    return spec


def test_resolution_order_config_dir_then_env_dir(fake_registry, tmp_path, monkeypatch) -> None:
    add(fake_registry, "http://127.0.0.1:9/none")
    a, b = tmp_path / "a", tmp_path / "b"
    for d in (a, b):
        (d / "demo" / "sub").mkdir(parents=True)
        (d / "demo" / "sub" / "file.csv").write_bytes(CONTENT)
    monkeypatch.setenv("GYM4REAL_DATA_DIR", str(b))
    assert datasets.resolve("demo/file", a) == a / "demo/sub/file.csv"
    assert datasets.resolve("demo/file") == b / "demo/sub/file.csv"


def test_download_into_cache_verified(fake_registry, server, tmp_path) -> None:
    add(fake_registry, f"{server}/good.csv")
    path = datasets.resolve("demo/file")
    assert path == tmp_path / "cache" / "demo/sub/file.csv"
    assert path.read_bytes() == CONTENT
    assert datasets.resolve("demo/file") == path  # now from the cache


def test_corrupt_download_leaves_nothing(fake_registry, server, tmp_path) -> None:
    add(fake_registry, f"{server}/bad.csv")
    with pytest.raises(DataFileError) as exc:
        datasets.resolve("demo/file")
    msg = str(exc.value)
    assert "demo/sub/file.csv" in msg and "GYM4REAL_DATA_DIR" in msg and "gym4real data fetch demo" in msg
    cache = tmp_path / "cache"
    assert not [p for p in cache.rglob("*") if p.is_file()]


def test_failed_download_names_every_place(fake_registry, server, tmp_path, monkeypatch) -> None:
    add(fake_registry, f"{server}/missing.csv")
    monkeypatch.setenv("GYM4REAL_DATA_DIR", str(tmp_path / "nowhere"))
    with pytest.raises(DataFileError) as exc:
        datasets.resolve("demo/file")
    msg = str(exc.value)
    assert "GYM4REAL_DATA_DIR" in msg and "user cache" in msg and "download from" in msg
    assert not [p for p in (tmp_path / "cache").rglob("*") if p.is_file()]


def test_offline_mode_does_not_download(fake_registry, server, monkeypatch) -> None:
    add(fake_registry, f"{server}/good.csv")
    monkeypatch.setenv("GYM4REAL_OFFLINE", "1")
    with pytest.raises(DataFileError, match="downloads are off"):
        datasets.resolve("demo/file")


def test_corrupt_user_file_is_reported_not_replaced(fake_registry, tmp_path, monkeypatch) -> None:
    add(fake_registry, "http://127.0.0.1:9/none")
    d = tmp_path / "data" / "demo" / "sub"
    d.mkdir(parents=True)
    (d / "file.csv").write_bytes(b"truncated")
    monkeypatch.setenv("GYM4REAL_DATA_DIR", str(tmp_path / "data"))
    with pytest.raises(DataFileError, match="corrupt"):
        datasets.resolve("demo/file")
    assert (d / "file.csv").read_bytes() == b"truncated"


def test_corrupt_cache_copy_is_dropped_and_fetched_again(fake_registry, server, tmp_path) -> None:
    add(fake_registry, f"{server}/good.csv")
    cached = tmp_path / "cache" / "demo" / "sub" / "file.csv"
    cached.parent.mkdir(parents=True)
    cached.write_bytes(b"half a fi")
    assert datasets.resolve("demo/file").read_bytes() == CONTENT


def test_upstream_builds_specs() -> None:
    [spec] = datasets.upstream("dam", "https://example.org/data/dam", {"mef": ("MEF.csv", SHA)}, "CC BY-NC 4.0")
    assert spec.name == "dam/mef" and spec.path == "dam/MEF.csv"
    assert spec.url == "https://example.org/data/dam/MEF.csv"
    [sub] = datasets.upstream("mg", "https://x/conf", {"pack": ("pack.yaml", SHA)}, "Apache-2.0", subdir="battery")
    assert sub.path == "mg/battery/pack.yaml" and sub.url == "https://x/conf/pack.yaml"


def test_unknown_dataset_lists_known(fake_registry) -> None:
    add(fake_registry, "http://127.0.0.1:9/none")
    with pytest.raises(DataFileError, match="demo/file"):
        datasets.resolve("demo/nope")
