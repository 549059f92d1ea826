"""``gym4real reproduce --check`` verifies every published file, and says what it cannot check here.

On a copy of ``docs/results``: each tampering (a changed number, a deleted or altered model, a changed hash,
a truncated manifest, an unknown file, a removed section, a bad byte, a truncated report) makes ``--check``
exit with the status of damaged files, naming the file and its section; the untouched copy is only short of
microgrid's synthetic training households where they are not synthesised: that section is *not checkable
here*, with the command that makes it checkable and its cost, never stale. ``gym4real evaluate`` and ``bench``
refuse a published model whose bytes differ from ``models.json``.
"""

from __future__ import annotations

import io
import json
import re
import shlex
import shutil
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from gym4real.results.artefacts import DamagedResultsError, verify
from gym4real.results.currency import NotCheckableError, StaleResultsError
from gym4real.results.published_models import sha256_of

RESULTS = Path(__file__).resolve().parents[1] / "docs" / "results"
_MANIFEST = json.loads((RESULTS / "manifest.json").read_text())


@pytest.fixture
def page(tmp_path: Path) -> Path:
    """A copy of the committed results page."""
    copy = tmp_path / "results"
    shutil.copytree(RESULTS, copy)
    return copy


def _check(folder: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str], str]:
    """``gym4real reproduce --check folder``: its exit status, output lines and error."""
    from gym4real.cli import main

    status = main(["reproduce", "--check", str(folder)])
    captured = capsys.readouterr()
    return status, captured.out.splitlines(), captured.err


def test_the_committed_page_is_every_file_its_manifest_and_models_list() -> None:
    assert verify(RESULTS).problems == {}


def test_the_untouched_copy_passes_and_a_section_without_its_data_is_not_checkable_here_not_stale(
    page: Path, data_without_training_households: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """It said "microgrid-v0-paper: stale: data.microgrid/demand/train: not found here" and advised retraining."""
    status, lines, err = _check(page, capsys)
    assert status == NotCheckableError.exit_status == 4
    sections = sorted(p.name for p in RESULTS.iterdir() if p.is_dir())
    assert [line.split(":")[0] for line in lines] == sections
    microgrid = [name for name in sections if name.startswith("microgrid-v0-")]  # the SB3 and JAX sections
    assert "microgrid-v0-paper" in microgrid
    others = [line for line in lines if line.split(":")[0] not in microgrid]
    assert others == [f"{name}: current" for name in sections if name not in microgrid]
    for name in microgrid:
        line = next(line for line in lines if line.startswith(f"{name}: "))
        assert line.startswith(
            f"{name}: not checkable here: it read the synthetic stand-in of `microgrid/demand/train`"
        )
        assert "`gym4real data synthesize microgrid`" in line and re.search(
            r"with a worker per core, in about \d+(\.\d+)? (s|min) on idle cores \(measured", line
        )
    assert f"{len(microgrid)} of {len(sections)} sections cannot be checked here ({', '.join(microgrid)})" in err
    said = (" ".join(lines) + err).lower()
    assert "stale" not in said and "train again" not in said and "retrain" not in said and "rerun" not in said


def test_the_exit_statuses_are_documented_in_the_help(capsys: pytest.CaptureFixture[str]) -> None:
    from gym4real.cli import main

    with pytest.raises(SystemExit):
        main(["reproduce", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "Exit status: 0 all current and every file as listed" in text
    for error, words in ((DamagedResultsError, "a file or section damaged"), (StaleResultsError, "a section stale")):
        assert f"{error.exit_status} {words}" in text
    assert f"{NotCheckableError.exit_status} a section not checkable here" in text
    assert (
        len({DamagedResultsError.exit_status, StaleResultsError.exit_status, NotCheckableError.exit_status, 0, 2}) == 5
    )


def _change_objective(page: Path) -> None:
    path = page / "dam-v0-paper" / "episodes.csv"
    header, first, *rest = path.read_bytes().split(b"\n")
    fields = first.split(b",")
    at = header.split(b",").index(b"objective")
    fields[at] = re.sub(rb"\d", lambda m: str((int(m.group()) + 1) % 10).encode(), fields[at], count=1)
    path.write_bytes(b"\n".join([header, b",".join(fields), *rest]))


def _alter_byte(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x01
    path.write_bytes(bytes(data))


def _change_listed_hash(page: Path) -> None:
    path = page / "dam-v0-paper" / "models.json"
    listing = json.loads(path.read_text())
    listing[2]["files"][0]["sha256"] = "0" * 64  # ppo seed 2's model.zip
    path.write_text(json.dumps(listing, indent=1) + "\n")


def _cut_in_half(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


#: Each tampering of the issue: what it does to the page, the section it names, what it says of the file.
TAMPERINGS: dict[str, tuple[Callable[[Path], object], str, list[str]]] = {
    "a changed number in episodes.csv": (_change_objective, "dam-v0-paper", ["dam-v0-paper/episodes.csv changed"]),
    "a deleted model file": (
        lambda p: (p / "wds-v0-paper" / "models" / "dqn-seed0" / "model.zip").unlink(),
        "wds-v0-paper",
        ["wds-v0-paper/models/dqn-seed0/model.zip missing (manifest.json and models.json list it)"],
    ),
    "an altered model file": (
        lambda p: _alter_byte(p / "dam-v0-paper" / "models" / "ppo-seed1" / "model.zip"),
        "dam-v0-paper",
        [
            "dam-v0-paper/models/ppo-seed1/model.zip changed: manifest.json lists 40848ede1a3c…; "
            "models.json lists 40848ede1a3c…"
        ],
    ),
    "a changed SHA-256 in models.json": (
        _change_listed_hash,
        "dam-v0-paper",
        [
            "dam-v0-paper/models.json changed: manifest.json lists",
            "dam-v0-paper/models/ppo-seed2/model.zip changed: models.json lists 000000000000…, the file has "
            "c2b4e8e0a1e4… (as manifest.json lists)",
        ],
    ),
    "manifest.json cut in half": (
        lambda p: _cut_in_half(p / "manifest.json"),
        "page",
        ["`manifest.json` is not valid JSON", "no file of the folder can be checked against it"],
    ),
    "an unknown extra file": (
        lambda p: (p / "trading-v0-paper" / "notes.txt").write_text("better numbers\n"),
        "trading-v0-paper",
        ["trading-v0-paper/notes.txt unknown (not in manifest.json)"],
    ),
    "a removed section folder": (
        lambda p: shutil.rmtree(p / "elevator-v0-paper"),
        "elevator-v0-paper",
        [
            "elevator-v0-paper/ missing: manifest.json lists this section and its "
            f"{len(_MANIFEST['provenance']['elevator-v0-paper']['files'])} files"
        ],
    ),
    "a non-UTF-8 byte in claims.json": (
        lambda p: (p / "wds-v0-paper" / "claims.json").write_bytes(
            b"\xff" + (p / "wds-v0-paper" / "claims.json").read_bytes()
        ),
        "wds-v0-paper",
        ["wds-v0-paper/claims.json changed"],
    ),
    "a truncated report.json": (
        lambda p: _cut_in_half(p / "robofeeder-picking-v0-paper" / "report.json"),
        "robofeeder-picking-v0-paper",
        [
            "robofeeder-picking-v0-paper/report.json changed",
            "`robofeeder-picking-v0-paper/report.json` is not valid JSON",
        ],
    ),
}


@pytest.mark.parametrize("tampering", list(TAMPERINGS))
def test_each_tampering_is_named_with_its_file_and_section_and_fails_the_check(
    tampering: str, page: Path, data_without_training_households: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: 11 of 13 such cases passed as "current" with exit 0, and a truncated report.json failed every
    section without naming the file."""
    tamper, section, said = TAMPERINGS[tampering]
    tamper(page)
    status, lines, err = _check(page, capsys)
    assert status == DamagedResultsError.exit_status == 5, err
    damaged = [line for line in lines if line.startswith(f"{section}: damaged: ")]
    for words in said:
        assert any(words in line for line in damaged), (words, lines)
    assert ("the page" if section == "page" else f"section {section}") in err
    assert not [line for line in lines if ": damaged: " in line and not line.startswith(f"{section}: ")]
    for name in ("dam-v0-paper", "trading-v0-paper", "wds-v0-paper"):  # the other sections are still checked
        assert f"{name}: current" in lines or name == section


def _changed_weights(path: Path) -> None:
    """Rewrite ``model.zip`` as a valid SB3 zip whose first policy weight is changed."""
    import torch

    with zipfile.ZipFile(path) as archive:
        entries = {name: archive.read(name) for name in archive.namelist()}
    weights = torch.load(io.BytesIO(entries["policy.pth"]), weights_only=True)
    first = next(iter(weights))
    weights[first] = weights[first] + 1e-3
    buffer = io.BytesIO()
    torch.save(weights, buffer)
    entries["policy.pth"] = buffer.getvalue()
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in entries.items():
            archive.writestr(name, data)


def _changed_statistics(path: Path) -> None:
    """Rewrite ``normalize.npz`` with its observation mean moved."""
    stats = dict(np.load(path, allow_pickle=False))
    stats["mean"] = stats["mean"] + 1e-3
    np.savez(path, **stats)


@pytest.mark.parametrize(("name", "change"), [("model.zip", _changed_weights), ("normalize.npz", _changed_statistics)])
def test_evaluate_refuses_a_published_model_whose_file_differs_from_its_listed_hash(
    name: str,
    change: Callable[[Path], None],
    page: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The listed command, run in the page folder, scored changed weights or statistics without a word."""
    pytest.importorskip("stable_baselines3")
    from gym4real.cli import main

    model = json.loads((page / "dam-v0-paper" / "models.json").read_text())[0]
    expected = next(f["sha256"] for f in model["files"] if f["name"] == name)
    file = page / "dam-v0-paper" / "models" / "ppo-seed0" / name
    change(file)
    actual = sha256_of(file)
    assert actual != expected
    argv = shlex.split(model["evaluate"].split(" (")[0])
    monkeypatch.chdir(page)
    assert main([*argv[1:], "--out", str(tmp_path / "evaluate")]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert f"`dam-v0-paper/models/ppo-seed0/{name}` is not the file of the published model ppo seed 0" in err
    assert f"lists SHA-256 {expected}, the file has {actual}" in err
    assert "git checkout -- dam-v0-paper/models/ppo-seed0" in err and model["retrain"] in err
    assert not (tmp_path / "evaluate" / "agent_episodes.csv").exists()


def test_bench_refuses_a_published_model_folder_with_a_file_its_listing_does_not_name(
    page: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from gym4real.cli import main

    folder = page / "wds-v0-paper" / "models" / "dqn-seed42"
    shutil.copy(page / "dam-v0-paper" / "models" / "ppo-seed0" / "normalize.npz", folder / "normalize.npz")
    monkeypatch.chdir(page)
    argv = ["bench", "gym4real/wds-v0", "--policies", "dqn:wds-v0-paper/models/dqn-seed42/model.zip", "--quiet"]
    assert main([*argv, "--out", str(tmp_path / "bench")]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert (
        "`wds-v0-paper/models/dqn-seed42` holds `normalize.npz`, which `wds-v0-paper/models.json` does not list" in err
    )


def test_a_model_outside_a_results_folder_is_not_checked(tmp_path: Path) -> None:
    from gym4real.bench.published import check_published

    copy = tmp_path / "mine" / "model.zip"
    copy.parent.mkdir()
    shutil.copy(RESULTS / "dam-v0-paper" / "models" / "ppo-seed0" / "model.zip", copy)
    _alter_byte(copy)
    check_published(copy)  # your own model: nothing listed to hold it to
