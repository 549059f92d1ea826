from __future__ import annotations

import hashlib
import http.server
import re
import threading
from collections.abc import Iterator
from functools import partial
from pathlib import Path

import pytest

from gym4real.cli import main
from gym4real.core import datasets
from gym4real.core.errors import DataFileError, DataUnreachableError
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


def test_an_unreachable_host_names_the_data_folder_and_no_unset_variable(fake_registry) -> None:
    add(fake_registry, "http://127.0.0.1:9/file.csv")  # nothing listens on the discard port: connection refused
    with pytest.raises(DataUnreachableError) as exc:
        datasets.resolve("demo/file")
    msg = str(exc.value)
    assert exc.value.host == "127.0.0.1" and "127.0.0.1 cannot be reached" in msg, msg
    assert "GYM4REAL_DATA_DIR (not set)" in msg and "Fix: set GYM4REAL_DATA_DIR" in msg, msg
    assert "gym4real data fetch" not in msg and "Max retries" not in msg, msg  # no retry from here can help


def test_the_upstream_data_folder_is_named_with_its_repository_and_commit() -> None:
    commit = "774d5ceb1c218e09e5c6458ead7d4b0b10e2d8ac"
    raw = f"https://raw.githubusercontent.com/Daveonwave/gym4ReaL/{commit}/gym4real"
    in_data = DatasetSpec(name="dam/mef", path="dam/MEF.csv", sha256=SHA, url=f"{raw}/data/dam/MEF.csv")
    elsewhere = DatasetSpec(name="mg/pack", path="mg/battery/pack.yaml", sha256=SHA, url=f"{raw}/envs/pack.yaml")
    assert (
        datasets.upstream_folder(in_data)
        == "the folder `gym4real/data` of github.com/Daveonwave/gym4ReaL at commit 774d5ce"
    )
    assert datasets.upstream_folder(elsewhere) is None
    assert datasets.where_to_get(elsewhere) == f"upstream: {raw}/envs/pack.yaml"


def table_rows(out: str) -> dict[str, list[str]]:
    """The rows of the table that starts ``out`` (cells two or more spaces apart): name -> [size, status, found in]."""
    header, *lines = out.splitlines()
    assert re.split(r"\s{2,}", header) == ["name", "size", "status", "found in"], header
    rows = {}
    for line in lines[: lines.index(next(x for x in lines if x.startswith("searched:")))]:
        name, *cells = re.split(r"\s{2,}", line.strip())
        rows[name] = cells
    return rows


def two_files(reg: dict[str, DatasetSpec], url: str, monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """``demo/a`` in GYM4REAL_DATA_DIR, ``demo/b`` and ``demo/c`` nowhere; all three at ``url``."""
    for key in "abc":
        reg[f"demo/{key}"] = DatasetSpec(name=f"demo/{key}", path=f"demo/{key}.csv", sha256=SHA, url=f"{url}/{key}")
    (tmp_path / "data" / "demo").mkdir(parents=True)
    (tmp_path / "data" / "demo" / "a.csv").write_bytes(CONTENT)
    monkeypatch.setenv("GYM4REAL_DATA_DIR", str(tmp_path / "data"))


def test_data_list_is_one_table_with_sizes_and_a_summary(fake_registry, tmp_path, monkeypatch, capsys) -> None:
    two_files(fake_registry, "http://127.0.0.1:9", monkeypatch, tmp_path)
    assert main(["data", "list"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert table_rows(out) == {
        "demo/a": ["17 B", "present", "GYM4REAL_DATA_DIR"],
        "demo/b": ["-", "missing", "-"],
        "demo/c": ["-", "missing", "-"],
    }
    assert f"GYM4REAL_DATA_DIR = {tmp_path / 'data'}" in lines[4]
    assert lines[5] == "3 data files: 1 here (17 B), 2 missing (demo/b, demo/c)"
    assert lines[6].startswith("Fix: set GYM4REAL_DATA_DIR") and "`gym4real data fetch demo`" in lines[6]
    assert max(len(line) for line in lines[:4]) < 120  # the table


def test_verify_does_not_blame_an_offline_switch_that_is_not_set(fake_registry, tmp_path, monkeypatch, capsys) -> None:
    two_files(fake_registry, "http://127.0.0.1:9", monkeypatch, tmp_path)
    (tmp_path / "data" / "demo" / "a.csv").write_bytes(b"other")
    assert main(["data", "verify"]) == 2
    out, err = capsys.readouterr()
    assert table_rows(out)["demo/a"] == ["5 B", "corrupt", "GYM4REAL_DATA_DIR"]
    assert "GYM4REAL_OFFLINE" not in out + err
    assert err.startswith("gym4real: error: 3 data files: 1 here (5 B), 1 corrupt (demo/a), 2 missing"), err
    assert "replace `demo/a.csv` in GYM4REAL_DATA_DIR with the upstream file http://127.0.0.1:9/a" in err


def test_fetch_stops_asking_a_host_that_cannot_be_reached(fake_registry, tmp_path, monkeypatch, capsys) -> None:
    two_files(fake_registry, "http://127.0.0.1:9", monkeypatch, tmp_path)
    tried = []
    download = datasets._download
    monkeypatch.setattr(
        datasets, "_download", lambda spec, deadline: tried.append(spec.name) or download(spec, deadline)
    )
    assert main(["data", "fetch"]) == 2
    out, err = capsys.readouterr()
    assert tried == ["demo/b"]
    assert table_rows(out) == {
        "demo/a": ["17 B", "ok", "GYM4REAL_DATA_DIR"],
        "demo/b": ["-", "failed", "-"],
        "demo/c": ["-", "skipped", "-"],
    }
    assert "127.0.0.1 cannot be reached (NewConnectionError): no further file was asked of it" in err, err
    assert "gym4real data fetch" not in err, err  # it never suggests itself for a network failure
