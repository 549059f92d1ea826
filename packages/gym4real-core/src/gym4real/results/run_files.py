"""The files of a training run's folder, checked whole before ``reproduce`` reuses or resumes the run.

A run folder holds JSON records (``settings.json``, ``run.json``, ``checkpoint/state.json``, ...), numpy
archives (``qtable.npz``, ``checkpoint.npz``, ``normalize.npz``, DQN's ``buffer.npz``), SB3 models
(``model.zip``) and the learning curve (``curve.csv``: every row as wide as its header, numbers only, and the
line break pandas ends it with; a file cut short ends mid-row). A file cut short (a full disk, a copy interrupted midway) would otherwise fail deep inside
training or testing with an error that names neither the file nor the run. :func:`damaged_file` reads each
of them whole; :class:`DamagedRunError` names the file and the run, and the folder is left as it is, unless
the user asks to move it aside and train the run again (:func:`move_aside`, ``reproduce --retrain-damaged``).
Temporary files of :func:`~gym4real.rl.storage.write_whole` (``*.tmp.*``, left by a process killed
midway) are not the run's files and are not read.
"""

from __future__ import annotations

import csv
import io
import json
import time
import zipfile
from pathlib import Path

import numpy as np

from gym4real.core.errors import Gym4RealError

#: The suffixes of the files that are checked, and how: JSON parsed, numpy archives and zip files read whole,
#: CSV tables read row by row.
CHECKED = (".json", ".npz", ".zip", ".csv")


class DamagedRunError(Gym4RealError):
    """A file of a training run's folder cannot be read (truncated, corrupt).

    Args:
        message: The run, the file, what is wrong and the fix.
        report: What the command had done and written before it stopped (printed by the CLI).
    """

    def __init__(self, message: str, report: str = "") -> None:
        super().__init__(message)
        self.report = report


def _read_whole(path: Path) -> None:
    """Read ``path`` as its suffix says, raising what the reader raises on a damaged file."""
    if path.suffix == ".json":
        json.loads(path.read_text())
    elif path.suffix == ".csv":
        _read_table(path.read_text())
    elif path.suffix == ".npz":
        with np.load(path, allow_pickle=False) as archive:
            for name in archive.files:
                archive[name]
    else:
        with zipfile.ZipFile(path) as archive:
            bad = archive.testzip()
            if bad is not None:
                raise zipfile.BadZipFile(f"member `{bad}` fails its CRC check")


def _read_table(text: str) -> None:
    """Check a CSV table written whole: a header, rows as wide as it of numbers (or empty cells), a final line break.

    Raises:
        ValueError: What is wrong and where (a table cut short ends without its line break, or mid-row).
    """
    if not text.endswith("\n"):
        raise ValueError("it does not end with a line break (cut short?)")
    header, *rows = csv.reader(io.StringIO(text))
    for number, row in enumerate(rows, start=2):
        if len(row) != len(header):
            raise ValueError(f"line {number} has {len(row)} fields, its header {len(header)}")
        for cell in row:
            if cell:
                float(cell)  # ValueError naming the cell


def damaged_file(folder: Path) -> tuple[Path, str] | None:
    """The first file of the run folder that cannot be read whole, and why; None when all can (or no folder)."""
    if not folder.is_dir():
        return None
    for path in sorted(folder.rglob("*")):
        if not path.is_file() or path.suffix not in CHECKED or ".tmp." in path.name:
            continue
        try:
            _read_whole(path)
        except Exception as exc:  # every reader's error on a damaged file: BadZipFile, EOFError, ValueError, ...
            return path, f"{type(exc).__name__}: {' '.join(str(exc).split())}"
    return None


def aside_name(folder: Path) -> Path:
    """Where :func:`move_aside` moves a damaged run folder: ``<folder>.damaged-<UTC time>``."""
    return folder.with_name(f"{folder.name}.damaged-{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}")


def move_aside(folder: Path) -> Path:
    """Move a damaged run folder aside (kept for inspection), so that its run trains again from the start."""
    target = aside_name(folder)
    folder.rename(target)
    return target


def check_run_folder(folder: Path, run: str, retrain_damaged: bool = False) -> None:
    """Refuse a run folder with a damaged file, or move it aside when ``retrain_damaged``.

    Args:
        folder: The run's folder.
        run: The run in words (``dam-v0 ppo seed 3``).
        retrain_damaged: Move a damaged folder aside (the run then trains again) instead of refusing it.

    Raises:
        DamagedRunError: Naming the run, the file and what is wrong; the folder is left untouched.
    """
    found = damaged_file(folder)
    if found is None:
        return
    if retrain_damaged:
        move_aside(folder)
        return
    path, why = found
    raise DamagedRunError(
        f"run `{run}`: its file `{path.relative_to(folder).as_posix()}` in `{folder}` is damaged ({why}); the "
        "folder was left as it is: restore the file, or rerun with `--retrain-damaged` to move the folder aside "
        f"(to `{folder.name}.damaged-<time>`) and train the run again"
    )
