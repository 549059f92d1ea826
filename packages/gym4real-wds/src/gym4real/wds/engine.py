"""The EPANET engine behind WDSEnv: one project handle per env, behind a small toolkit interface.

Two backends expose the same functional toolkit API (the subset of owa-epanet's ``epanet.toolkit`` that
the environment calls):

* ``owa-epanet`` (default): the OpenWaterAnalytics SWIG binding, EPANET 2.3.05.
* ``epyt`` (fallback where owa-epanet has no wheel): the EPANET 2.3.05 library that the ``epyt`` package
  bundles, called through :mod:`ctypes` with typed signatures (epyt's own Python layer is not imported:
  it pulls matplotlib and writes temporary copies of the network beside the input file).

Both run the same engine build, so results are identical. :class:`Engine` owns one project: it opens
the network once, with its report file in a private temporary folder (removed as soon as the file is
open on POSIX, else at :meth:`Engine.close`), starts a fresh hydraulic solver per episode, and releases
everything at ``close()``. EPANET errors become :class:`EpanetError` (or ``DataFileError`` for a network
EPANET cannot read) carrying EPANET's message.
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib.metadata
import importlib.util
import os
import re
import shutil
import sys
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from gym4real.core.errors import ConfigError, DataFileError, Gym4RealError
from gym4real.wds.inp_check import check_network_text

# EPANET 2.3 toolkit codes (epanet2_enums.h); identical in every 2.2+ build.
NODECOUNT, LINKCOUNT, CONTROLCOUNT, RULECOUNT = 0, 2, 5, 6
JUNCTION, RESERVOIR, TANK = 0, 1, 2
PUMP = 2
ELEVATION, DEMAND, HEAD, PRESSURE = 0, 9, 10, 11
INIT_FLOWS = 10  # EN_initH flag: re-initialise link flows, do not save results
TANKLEVEL, TANKDIAM, MINVOLUME, VOLCURVE, MINLEVEL, MAXLEVEL, TANKVOLUME, MAXVOLUME = 8, 17, 18, 19, 20, 21, 24, 25
DEMANDFLOW, FULLDEMAND = 31, 32
INITSTATUS, FLOW, STATUS, SETTING, PUMP_POWER = 4, 8, 11, 12, 18
LOWLEVEL, HILEVEL = 0, 1  # simple control types
DURATION, HYDSTEP, PATTERNSTEP, PATTERNSTART, REPORTSTEP = 0, 1, 3, 4, 5
DDA, PDA = 0, 1
CONST_HP = 0

#: Flow units code -> m³/h per flow unit (CFS, GPM, MGD, IMGD, AFD, LPS, LPM, MLD, CMH, CMD, CMS).
FLOW_TO_M3H = (101.9406919, 0.2271247, 157.7255, 189.4164, 51.39285, 3.6, 0.06, 41.66667, 1.0, 1 / 24, 3600.0)
#: Flow units codes of networks whose lengths and pressures are metric (m).
SI_FLOW_UNITS = frozenset({5, 6, 7, 8, 9, 10})

ENGINES = ("owa-epanet", "epyt")
PINS = {"owa-epanet": "2.3.5", "epyt": "2.3.5.3"}
INSTALL_HINT = (
    f"`pip install owa-epanet=={PINS['owa-epanet']}` (wheels: CPython 3.11/3.12 on Linux x86-64, 3.11 on macOS "
    f"arm64), or elsewhere `pip install epyt=={PINS['epyt']}`"
)


class EpanetError(Gym4RealError, RuntimeError):
    """EPANET returned an error code (the message is EPANET's)."""


# -- backends ----------------------------------------------------------------------------------------


class _OwaBackend:
    """owa-epanet: the toolkit module itself; bulk buffers are SWIG ``doubleArray`` seen through numpy."""

    name = "owa-epanet"

    def __init__(self) -> None:
        from epanet import toolkit

        self.tk: Any = toolkit
        self.version = importlib.metadata.version("owa-epanet")

    def buffer(self, n: int) -> tuple[Any, np.ndarray]:
        arr = self.tk.doubleArray(max(n, 1))
        view = np.ctypeslib.as_array((ctypes.c_double * max(n, 1)).from_address(int(arr.cast())))
        return arr, view  # keep `arr` alive as long as `view`

    def run(self, ph: Any) -> int:
        t: int = self.tk.runH(ph)  # its bare `Warning("WARNING")` is ignored (see ignore_engine_warnings)
        return t


def ignore_engine_warnings() -> None:
    """Ignore owa-epanet's bare ``Warning("WARNING")``, raised from this module's calls only.

    owa-epanet turns EPANET's warning codes (1..6) into that warning; their effect (for example a pump
    closed because it cannot deliver its head) shows in flows and pressures. One filter, narrowed to this
    message, category and module, set at import and again when an engine opens (a test runner may have
    restored the filters since): entering ``warnings.catch_warnings`` around every ``runH`` cost ~15 % of
    a step. Every other warning is shown as the user's filters say.
    """
    warnings.filterwarnings("ignore", message="WARNING$", category=Warning, module=re.escape(__name__) + "$")


ignore_engine_warnings()


# ctypes argument types of the EPANET API (a project handle is a void pointer)
_P, _I, _D, _S = ctypes.c_void_p, ctypes.c_int, ctypes.c_double, ctypes.c_char_p
_pP, _pI, _pD, _pL = (ctypes.POINTER(t) for t in (ctypes.c_void_p, ctypes.c_int, ctypes.c_double, ctypes.c_long))


class _CtypesToolkit:
    """The owa-epanet functions the env calls, implemented on a raw EPANET 2.3 library with ctypes."""

    _SIGNATURES: dict[str, tuple[Any, ...]] = {
        "EN_createproject": (_pP,),
        "EN_deleteproject": (_P,),
        "EN_open": (_P, _S, _S, _S),
        "EN_close": (_P,),
        "EN_getcount": (_P, _I, _pI),
        "EN_getnodeid": (_P, _I, _S),
        "EN_getnodetype": (_P, _I, _pI),
        "EN_getlinkid": (_P, _I, _S),
        "EN_getlinktype": (_P, _I, _pI),
        "EN_getlinknodes": (_P, _I, _pI, _pI),
        "EN_getnodevalue": (_P, _I, _I, _pD),
        "EN_getlinkvalue": (_P, _I, _I, _pD),
        "EN_setlinkvalue": (_P, _I, _I, _D),
        "EN_setnodevalue": (_P, _I, _I, _D),
        "EN_getnodevalues": (_P, _I, _P),
        "EN_getnumdemands": (_P, _I, _pI),
        "EN_getbasedemand": (_P, _I, _I, _pD),
        "EN_setdemandpattern": (_P, _I, _I, _I),
        "EN_addpattern": (_P, _S),
        "EN_getpatternindex": (_P, _S, _pI),
        "EN_setpattern": (_P, _I, _P, _I),
        "EN_gettimeparam": (_P, _I, _pL),
        "EN_settimeparam": (_P, _I, ctypes.c_long),
        "EN_getdemandmodel": (_P, _pI, _pD, _pD, _pD),
        "EN_setdemandmodel": (_P, _I, _D, _D, _D),
        "EN_getflowunits": (_P, _pI),
        "EN_getcontrol": (_P, _I, _pI, _pI, _pD, _pI, _pD),
        "EN_addcontrol": (_P, _I, _I, _D, _I, _D, _pI),
        "EN_setcontrolenabled": (_P, _I, _I),
        "EN_getrule": (_P, _I, _pI, _pI, _pI, _pD),
        "EN_getthenaction": (_P, _I, _I, _pI, _pI, _pD),
        "EN_getelseaction": (_P, _I, _I, _pI, _pI, _pD),
        "EN_setruleenabled": (_P, _I, _I),
        "EN_getpumptype": (_P, _I, _pI),
        "EN_getheadcurveindex": (_P, _I, _pI),
        "EN_getcurvelen": (_P, _I, _pI),
        "EN_getcurvevalue": (_P, _I, _I, _pD, _pD),
        "EN_setcurvevalue": (_P, _I, _I, _D, _D),
        "EN_openH": (_P,),
        "EN_initH": (_P, _I),
        "EN_runH": (_P, _pL),
        "EN_nextH": (_P, _pL),
        "EN_closeH": (_P,),
        "EN_geterror": (_I, _S, _I),
        "EN_getversion": (_pI,),
    }

    def __init__(self, library: Path) -> None:
        self._lib = lib = ctypes.CDLL(str(library))  # a private handle: no global ctypes patches
        for name, argtypes in self._SIGNATURES.items():
            fn = getattr(lib, name)
            fn.argtypes = list(argtypes)
            fn.restype = ctypes.c_int
        self._d1, self._d2, self._d3 = ctypes.c_double(), ctypes.c_double(), ctypes.c_double()
        self._i1, self._i2, self._i3 = ctypes.c_int(), ctypes.c_int(), ctypes.c_int()
        self._l1 = ctypes.c_long()
        self._id = ctypes.create_string_buffer(64)

    def _check(self, code: int) -> None:
        if code >= 100:
            buf = ctypes.create_string_buffer(256)
            self._lib.EN_geterror(code, buf, 255)
            raise EpanetError(buf.value.decode(errors="replace") or f"Error {code}")
        # codes 1..99 are warnings, ignored as with owa-epanet (see `_OwaBackend.run`)

    # project
    def createproject(self) -> ctypes.c_void_p:
        ph = ctypes.c_void_p()
        self._check(self._lib.EN_createproject(ctypes.byref(ph)))
        return ph

    def deleteproject(self, ph: Any) -> None:
        self._check(self._lib.EN_deleteproject(ph))

    def open(self, ph: Any, inp: str, rpt: str, out: str) -> None:
        self._check(self._lib.EN_open(ph, os.fsencode(inp), os.fsencode(rpt), os.fsencode(out)))

    def close(self, ph: Any) -> None:
        self._check(self._lib.EN_close(ph))

    def getversion(self) -> int:
        self._check(self._lib.EN_getversion(ctypes.byref(self._i1)))
        return self._i1.value

    def _int(self, fn: Any, *args: Any) -> int:
        self._check(fn(*args, ctypes.byref(self._i1)))
        return self._i1.value

    def _double(self, fn: Any, *args: Any) -> float:
        self._check(fn(*args, ctypes.byref(self._d1)))
        return self._d1.value

    def _text(self, fn: Any, *args: Any) -> str:
        self._check(fn(*args, self._id))
        return self._id.value.decode(errors="replace")

    # network
    def getcount(self, ph: Any, code: int) -> int:
        return self._int(self._lib.EN_getcount, ph, code)

    def getnodeid(self, ph: Any, i: int) -> str:
        return self._text(self._lib.EN_getnodeid, ph, i)

    def getnodetype(self, ph: Any, i: int) -> int:
        return self._int(self._lib.EN_getnodetype, ph, i)

    def getlinkid(self, ph: Any, i: int) -> str:
        return self._text(self._lib.EN_getlinkid, ph, i)

    def getlinktype(self, ph: Any, i: int) -> int:
        return self._int(self._lib.EN_getlinktype, ph, i)

    def getlinknodes(self, ph: Any, i: int) -> list[int]:
        self._check(self._lib.EN_getlinknodes(ph, i, ctypes.byref(self._i1), ctypes.byref(self._i2)))
        return [self._i1.value, self._i2.value]

    def getnodevalue(self, ph: Any, i: int, prop: int) -> float:
        return self._double(self._lib.EN_getnodevalue, ph, i, prop)

    def getlinkvalue(self, ph: Any, i: int, prop: int) -> float:
        return self._double(self._lib.EN_getlinkvalue, ph, i, prop)

    def setlinkvalue(self, ph: Any, i: int, prop: int, value: float) -> None:
        self._check(self._lib.EN_setlinkvalue(ph, i, prop, value))

    def setnodevalue(self, ph: Any, i: int, prop: int, value: float) -> None:
        self._check(self._lib.EN_setnodevalue(ph, i, prop, value))

    def getnodevalues(self, ph: Any, prop: int, out: np.ndarray) -> None:
        self._check(self._lib.EN_getnodevalues(ph, prop, out.ctypes.data))

    def getnumdemands(self, ph: Any, i: int) -> int:
        return self._int(self._lib.EN_getnumdemands, ph, i)

    def getbasedemand(self, ph: Any, i: int, d: int) -> float:
        return self._double(self._lib.EN_getbasedemand, ph, i, d)

    def setdemandpattern(self, ph: Any, i: int, d: int, pattern: int) -> None:
        self._check(self._lib.EN_setdemandpattern(ph, i, d, pattern))

    def addpattern(self, ph: Any, name: str) -> None:
        self._check(self._lib.EN_addpattern(ph, name.encode()))

    def getpatternindex(self, ph: Any, name: str) -> int:
        return self._int(self._lib.EN_getpatternindex, ph, name.encode())

    def setpattern(self, ph: Any, index: int, values: np.ndarray, n: int) -> None:
        self._check(self._lib.EN_setpattern(ph, index, values.ctypes.data, n))

    def gettimeparam(self, ph: Any, code: int) -> int:
        self._check(self._lib.EN_gettimeparam(ph, code, ctypes.byref(self._l1)))
        return self._l1.value

    def settimeparam(self, ph: Any, code: int, value: int) -> None:
        self._check(self._lib.EN_settimeparam(ph, code, value))

    def getdemandmodel(self, ph: Any) -> list[float]:
        i, a, b, c = self._i1, self._d1, self._d2, self._d3
        self._check(self._lib.EN_getdemandmodel(ph, ctypes.byref(i), ctypes.byref(a), ctypes.byref(b), ctypes.byref(c)))
        return [i.value, a.value, b.value, c.value]

    def setdemandmodel(self, ph: Any, model: int, pmin: float, preq: float, pexp: float) -> None:
        self._check(self._lib.EN_setdemandmodel(ph, model, pmin, preq, pexp))

    def getflowunits(self, ph: Any) -> int:
        return self._int(self._lib.EN_getflowunits, ph)

    def getcontrol(self, ph: Any, i: int) -> list[float]:
        t, link, node = ctypes.c_int(), ctypes.c_int(), ctypes.c_int()
        setting, level = ctypes.c_double(), ctypes.c_double()
        self._check(
            self._lib.EN_getcontrol(
                ph,
                i,
                ctypes.byref(t),
                ctypes.byref(link),
                ctypes.byref(setting),
                ctypes.byref(node),
                ctypes.byref(level),
            )
        )
        return [t.value, link.value, setting.value, node.value, level.value]

    def addcontrol(self, ph: Any, kind: int, link: int, setting: float, node: int, level: float) -> int:
        return self._int(self._lib.EN_addcontrol, ph, kind, link, setting, node, level)

    def setcontrolenabled(self, ph: Any, i: int, enabled: int) -> None:
        self._check(self._lib.EN_setcontrolenabled(ph, i, enabled))

    def getrule(self, ph: Any, i: int) -> list[float]:
        a, b, c, prio = ctypes.c_int(), ctypes.c_int(), ctypes.c_int(), ctypes.c_double()
        self._check(self._lib.EN_getrule(ph, i, ctypes.byref(a), ctypes.byref(b), ctypes.byref(c), ctypes.byref(prio)))
        return [a.value, b.value, c.value, prio.value]

    def _action(self, fn: Any, ph: Any, rule: int, k: int) -> list[float]:
        link, status, setting = ctypes.c_int(), ctypes.c_int(), ctypes.c_double()
        self._check(fn(ph, rule, k, ctypes.byref(link), ctypes.byref(status), ctypes.byref(setting)))
        return [link.value, status.value, setting.value]

    def getthenaction(self, ph: Any, rule: int, k: int) -> list[float]:
        return self._action(self._lib.EN_getthenaction, ph, rule, k)

    def getelseaction(self, ph: Any, rule: int, k: int) -> list[float]:
        return self._action(self._lib.EN_getelseaction, ph, rule, k)

    def setruleenabled(self, ph: Any, i: int, enabled: int) -> None:
        self._check(self._lib.EN_setruleenabled(ph, i, enabled))

    def getpumptype(self, ph: Any, i: int) -> int:
        return self._int(self._lib.EN_getpumptype, ph, i)

    def getheadcurveindex(self, ph: Any, i: int) -> int:
        return self._int(self._lib.EN_getheadcurveindex, ph, i)

    def getcurvelen(self, ph: Any, i: int) -> int:
        return self._int(self._lib.EN_getcurvelen, ph, i)

    def getcurvevalue(self, ph: Any, curve: int, k: int) -> list[float]:
        self._check(self._lib.EN_getcurvevalue(ph, curve, k, ctypes.byref(self._d1), ctypes.byref(self._d2)))
        return [self._d1.value, self._d2.value]

    def setcurvevalue(self, ph: Any, curve: int, k: int, x: float, y: float) -> None:
        self._check(self._lib.EN_setcurvevalue(ph, curve, k, x, y))

    # hydraulics
    def openH(self, ph: Any) -> None:
        self._check(self._lib.EN_openH(ph))

    def initH(self, ph: Any, flag: int) -> None:
        self._check(self._lib.EN_initH(ph, flag))

    def runH(self, ph: Any) -> int:
        self._check(self._lib.EN_runH(ph, ctypes.byref(self._l1)))
        return self._l1.value

    def nextH(self, ph: Any) -> int:
        self._check(self._lib.EN_nextH(ph, ctypes.byref(self._l1)))
        return self._l1.value

    def closeH(self, ph: Any) -> None:
        self._check(self._lib.EN_closeH(ph))


def _epyt_library() -> Path:
    """Path of the EPANET library bundled in the installed ``epyt`` package (epyt itself is not imported)."""
    spec = importlib.util.find_spec("epyt")
    if spec is None or not spec.submodule_search_locations:
        raise ModuleNotFoundError("No module named 'epyt'", name="epyt")
    root = Path(next(iter(spec.submodule_search_locations))) / "libraries"
    if sys.platform.startswith("win"):
        lib = root / "win" / "epanet2.dll"
    elif sys.platform == "darwin":
        lib = root / "mac" / "libepanet2.dylib"
    else:
        lib = root / "glnx" / "libepanet2.so"
    if not lib.is_file():
        msg = f"the installed epyt has no EPANET library for this platform at `{lib}`; install {INSTALL_HINT}"
        raise ConfigError(msg)
    return lib


class _CtypesBackend:
    """epyt's bundled EPANET library through :class:`_CtypesToolkit`; bulk buffers are numpy arrays."""

    name = "epyt"

    def __init__(self) -> None:
        self.tk: Any = _CtypesToolkit(_epyt_library())
        self.version = importlib.metadata.version("epyt")

    def buffer(self, n: int) -> tuple[Any, np.ndarray]:
        arr = np.zeros(max(n, 1))
        return arr, arr

    def run(self, ph: Any) -> int:
        t: int = self.tk.runH(ph)
        return t


_BACKENDS: dict[str, Any] = {}


def backend(kind: str = "auto") -> Any:
    """Return the (process-wide, stateless) backend ``kind``: ``auto``, ``owa-epanet`` or ``epyt``.

    Raises:
        ConfigError: An unknown kind, or no usable engine installed (the message says what to install).
    """
    if kind not in ("auto", *ENGINES):
        raise ConfigError(f"unknown `engine` {kind!r}; expected `auto`, `owa-epanet` or `epyt`")
    order = ENGINES if kind == "auto" else (kind,)
    errors = []
    for name in order:
        if name in _BACKENDS:
            return _BACKENDS[name]
        try:
            _BACKENDS[name] = _OwaBackend() if name == "owa-epanet" else _CtypesBackend()
            return _BACKENDS[name]
        except (ImportError, OSError) as exc:
            errors.append(f"{name}: {type(exc).__name__}: {exc}")
    msg = f"no EPANET engine available ({'; '.join(errors)}); install {INSTALL_HINT}"
    raise ConfigError(msg)


def format_version(code: int) -> str:
    """EPANET's version code as text: 20305 -> ``2.3.05``."""
    return f"{code // 10000}.{code // 100 % 100}.{code % 100:02d}"


def engine_info(kind: str = "auto") -> dict[str, Any]:
    """What ``env_info`` and ``info["engine"]`` report: the engine in use and its versions."""
    try:
        b = backend(kind)
    except ConfigError as exc:
        return {"engine": None, "engine_error": str(exc)}
    epanet = format_version(b.tk.getversion())
    return {
        "engine": b.name,
        "engine_version": b.version,
        "epanet_version": epanet,
        "engine_label": f"{b.name} {b.version} (EPANET {epanet})",
        "engine_pin": PINS[b.name],
    }


def _report_errors(report: Path) -> str:
    try:
        text = report.read_text(errors="replace")
    except OSError:
        return ""
    lines = [ln.strip() for ln in text.splitlines()]
    keep = [ln for i, ln in enumerate(lines) if ln.startswith("Error") or (i and lines[i - 1].startswith("Error"))]
    return " | ".join(ln for ln in keep if ln)


#: Control characters a text file does not hold (tab, line feed and carriage return are text).
CONTROL = re.compile(r"[\x00-\x08\x0b-\x0c\x0e-\x1f\x7f]")


def check_text(path: Path) -> None:
    """Refuse a network file that is not UTF-8 text, naming the line.

    EPANET reads a number up to the first byte it cannot parse and keeps the value so far when that byte
    is a NUL or above 0x7f (``3657.6``, bytes ``ff 00``, ``001`` reads as 3657.6): such a file opens and
    silently simulates another network.

    Raises:
        DataFileError: A byte sequence that is not UTF-8, or a control character (other than tab and line
            ends), with its line and column.
    """
    data = path.read_bytes()
    try:
        text = data.decode("utf-8")  # a byte-order mark decodes to U+FEFF, which EPANET skips
    except UnicodeDecodeError as exc:
        line, start = data.count(b"\n", 0, exc.start) + 1, data.rfind(b"\n", 0, exc.start) + 1
        where = f"line {line}, byte {exc.start - start + 1}"
        problem = f"is not UTF-8 text ({where}: byte 0x{data[exc.start]:02x}, {exc.reason})"
    else:
        bad = CONTROL.search(text)
        if bad is None:
            return
        line, start = text.count("\n", 0, bad.start()) + 1, text.rfind("\n", 0, bad.start()) + 1
        where = f"line {line}, column {bad.start() - start + 1}"
        problem = f"is not text ({where}: control character U+{ord(bad.group()):04X})"
    msg = (
        f"network file `{path}` {problem}; EPANET would read the field holding it as another value: remove the "
        "binary bytes, or save the network again from EPANET as UTF-8 text"
    )
    raise DataFileError(msg)


class Engine:
    """One EPANET project: a network opened once, hydraulics initialised per episode.

    Args:
        inp: The ``.inp`` network file.
        kind: ``auto``, ``owa-epanet`` or ``epyt``.

    Raises:
        DataFileError: The file is missing, is not text (:func:`check_text`), is cut short or holds a pump
            EPANET cannot solve (:func:`~gym4real.wds.inp_check.check_network_text`), or EPANET rejects it
            (EPANET's messages, with line details).
    """

    def __init__(self, inp: str | Path, kind: str = "auto") -> None:
        self.backend = b = backend(kind)
        self.tk: Any = b.tk
        ignore_engine_warnings()
        self.path = Path(inp)
        self.ph: Any = None
        self._hyd_open = False
        self._buffers: dict[tuple[str, int], tuple[Any, np.ndarray]] = {}
        if not self.path.is_file():
            problem = "is a folder, not a file" if self.path.is_dir() else "does not exist"
            raise DataFileError(f"network file `{self.path}` {problem}; pass an EPANET `.inp` file as `network`")
        check_text(self.path)
        check_network_text(self.path, self.path.read_text(encoding="utf-8-sig"))
        self._tmp: str | None = tempfile.mkdtemp(prefix="gym4real-wds-")
        report = Path(self._tmp) / "epanet.rpt"
        self.ph = self.tk.createproject()
        try:
            self.tk.open(self.ph, str(self.path), str(report), "")
        except Exception as exc:
            ph, self.ph = self.ph, None
            for step in ("close", "deleteproject"):  # closes the report file so that its details can be read
                with contextlib.suppress(Exception):
                    getattr(self.tk, step)(ph)
            detail = _report_errors(report)
            self._drop_tmp()
            msg = f"EPANET cannot read network `{self.path}`: {exc}" + (f" ({detail})" if detail else "")
            raise DataFileError(msg) from None
        self._drop_tmp()  # POSIX: the open report file outlives its unlinked folder
        self.n_nodes: int = self.tk.getcount(self.ph, NODECOUNT)

    def _drop_tmp(self) -> None:
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
            if not os.path.exists(self._tmp):
                self._tmp = None

    @property
    def label(self) -> str:
        """``owa-epanet 2.3.5 (EPANET 2.3.05)``."""
        return f"{self.backend.name} {self.backend.version} (EPANET {format_version(self.tk.getversion())})"

    def node_values(self, prop: int) -> np.ndarray:
        """Every node's value of a property (a view into a buffer that the next call for ``prop`` reuses)."""
        key = ("node", prop)
        if key not in self._buffers:
            handle, view = self.backend.buffer(self.n_nodes)
            self._buffers[key] = (handle, view[: self.n_nodes])
        handle, view = self._buffers[key]
        self.tk.getnodevalues(self.ph, prop, handle)
        return view

    def set_pattern(self, index: int, values: np.ndarray) -> None:
        """Replace the multipliers of pattern ``index`` (any length)."""
        handle, view = self.backend.buffer(len(values))
        view[: len(values)] = values
        self.tk.setpattern(self.ph, index, handle, len(values))

    # hydraulics: thin wrappers turning EPANET's exceptions into EpanetError

    def init_hydraulics(self) -> None:
        """Start an episode: a fresh hydraulic solver (``closeH``, ``openH``) and ``EN_initH(10)``.

        ``EN_initH(0)`` resets the clock, tank levels and link status but keeps solver state of the last
        episode: the pressure-driven demands and the link flows EPANET starts its iterations from (flag
        10 re-initialises the flows). Either moves results in the seventh digit and breaks same-seed
        determinism; re-opening the solver costs about 15 µs.
        """
        if self._hyd_open:
            self._call("closeH", self.tk.closeH, self.ph)
            self._hyd_open = False
        self._call("openH", self.tk.openH, self.ph)
        self._hyd_open = True
        self._call("initH", self.tk.initH, self.ph, INIT_FLOWS)

    def run(self) -> int:
        """``EN_runH``: solve at the current clock time; returns the time (s)."""
        return self._call("runH", self.backend.run, self.ph)  # type: ignore[no-any-return]

    def next(self) -> int:
        """``EN_nextH``: advance to the next hydraulic event; returns the step (s), 0 at the end."""
        return self._call("nextH", self.tk.nextH, self.ph)  # type: ignore[no-any-return]

    @staticmethod
    def _call(what: str, fn: Any, *args: Any) -> Any:
        try:
            return fn(*args)
        except EpanetError:
            raise
        except Exception as exc:  # owa-epanet raises a bare Exception("Error 2xx: ...")
            raise EpanetError(f"EPANET {what} failed: {exc}") from None

    def close(self) -> None:
        """Release the solver, the project and the temporary folder (idempotent)."""
        ph, self.ph = self.ph, None
        if ph is not None:
            for step in ("closeH", "close", "deleteproject"):
                if step == "closeH" and not self._hyd_open:
                    continue
                with contextlib.suppress(Exception):  # best effort while releasing
                    getattr(self.tk, step)(ph)
            self._hyd_open = False
        self._buffers.clear()
        self._drop_tmp()
