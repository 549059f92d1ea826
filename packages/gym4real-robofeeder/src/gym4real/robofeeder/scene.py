"""The MuJoCo scene: the reference MJCF with N objects, built in memory from the registered files.

Every file is resolved through the core dataset registry (checksummed, ``GYM4REAL_DATA_DIR``, cache)
and handed to MuJoCo as an in-memory asset keyed by its file name, so relative ``meshdir`` and
``include`` paths never matter and nothing is written anywhere: the reference's generated
``object_v2.xml`` (defect 3) becomes a string built from ``object_v2pattern.xml``.
"""

from __future__ import annotations

import copy
import functools
import re
from pathlib import Path, PurePosixPath

from gym4real.core.datasets import resolve
from gym4real.core.errors import DataFileError
from gym4real.robofeeder._gl import mujoco
from gym4real.robofeeder._plugin import DOMAIN, MODEL_FILES

MAIN_XML = "urdf/tx2_60.xml"
PATTERN_XML = "urdf/object_v2pattern.xml"
BOX_XML = "urdf/box.xml"

#: One object body as the reference's `obj_configurator` writes it (pose replaced at reset).
_OBJECT_BODY = """
    <body name="object{i}" pos="-0.35 0.35 0.21" quat="1 0 0 0">
      <site name="site_obj{i}" pos="0.002 -0.013 0.0" size="0.017" material="highlight" type="sphere"/>
      <joint type="free" limited="auto" armature="0.000001"/>
      <inertial pos="0 0 0" mass="0.1" diaginertia="0.0001 0.0001 0.0001"/>
      <geom name="obj{i}" material="Iron_Scratched" mesh="object" class="visual1"/>
      <geom mesh="object_collision_0" class="collision1"/>
      <geom mesh="object_collision_1" class="collision1" margin="0.00075"/>
      <geom mesh="object_collision_2" class="collision1" margin="0.00075"/>
      <geom mesh="object_collision_3" class="collision1"/>
      <geom mesh="object_collision_4" class="collision1"/>
    </body>"""

_FILE_ATTR = re.compile(r"""\bfile\s*=\s*["']([^"']+)["']""")
_COMMENT = re.compile(r"<!--.*?-->", re.DOTALL)
_MESHDIR = re.compile(r"""\bmeshdir\s*=\s*["'][^"']*["']""")


def _read_text(path: Path, what: str, *, closed: bool = True) -> str:
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(f"cannot read the RoboFeeder {what} `{path}`: {exc}") from exc
    if "<mujoco" not in text or (closed and "</mujoco>" not in text):
        raise DataFileError(f"`{path}` is not the RoboFeeder {what}: expected an MJCF `<mujoco>` document")
    return text


def _mesh_bytes(path: Path, rel: str) -> bytes:
    """A mesh file's bytes; an empty mesh (no byte, no vertex, no triangle) is named, not blamed on the MJCF."""
    data = path.read_bytes()
    problem = ""
    if not data.strip():
        problem = "is empty"
    elif rel.endswith(".obj"):
        vertices = sum(1 for line in data.splitlines() if line.startswith(b"v "))
        if vertices < 4:
            problem = f"holds {vertices} vertices (a mesh needs at least 4)"
    elif rel.endswith(".stl"):
        ascii_stl = data.lstrip().startswith(b"solid") and b"facet" in data
        triangles = 1 if ascii_stl else int.from_bytes(data[80:84], "little") if len(data) >= 84 else 0
        if not triangles:
            problem = "holds no triangle"
    if problem:
        msg = (
            f"RoboFeeder mesh file `{path}` (`{rel}`) {problem}; expected the registered STL/OBJ mesh. Fix: "
            "replace it with the upstream file (`gym4real data fetch robofeeder`)"
        )
        raise DataFileError(msg)
    return data


def objects_xml(pattern: str, n_objects: int) -> str:
    """The reference's ``object_v2.xml`` with ``n_objects`` bodies, as a string."""
    if "<worldbody>" not in pattern:
        raise DataFileError(f"`{PATTERN_XML}` has no `<worldbody>`: expected the reference object pattern")
    bodies = "".join(_OBJECT_BODY.format(i=i) for i in range(n_objects))
    return f"{pattern.rstrip()}\n{bodies}\n  </worldbody>\n</mujoco>\n"


def model_paths(data_dir: str | None) -> dict[str, Path]:
    """Resolve every registered model file (relative path below ``model/`` -> local path)."""
    return {rel: resolve(f"{DOMAIN}/model/{rel}", data_dir) for rel in MODEL_FILES}


@functools.lru_cache(maxsize=8)
def _compiled(paths: tuple[tuple[str, Path], ...], n_objects: int) -> mujoco.MjModel:
    files = dict(paths)
    main = _read_text(files[MAIN_XML], "robot MJCF")
    box = _read_text(files[BOX_XML], "bin MJCF")
    pattern = _read_text(files[PATTERN_XML], "object pattern", closed=False)
    generated = objects_xml(pattern, n_objects)
    assets: dict[str, bytes] = {"object_v2.xml": generated.encode(), "box.xml": box.encode()}
    by_name = {PurePosixPath(rel).name: (rel, path) for rel, path in files.items() if rel.startswith("meshes/")}
    for text, source in ((main, MAIN_XML), (box, BOX_XML), (generated, PATTERN_XML)):
        for name in _FILE_ATTR.findall(_COMMENT.sub("", text)):
            if name in assets:
                continue
            if name not in by_name:
                msg = f"`{source}` references `{name}`, which is not a registered RoboFeeder model file"
                raise DataFileError(msg)
            assets[name] = _mesh_bytes(by_name[name][1], by_name[name][0])
    main = _MESHDIR.sub('meshdir=""', main, count=1)
    try:
        return mujoco.MjModel.from_xml_string(main, assets=assets)
    except ValueError as exc:
        raise DataFileError(f"the RoboFeeder MJCF (`{files[MAIN_XML]}`) does not compile: {exc}") from exc


def build_model(n_objects: int, data_dir: str | None = None) -> mujoco.MjModel:
    """A private copy of the compiled scene with ``n_objects`` objects (compiled once per process)."""
    paths = model_paths(data_dir)
    template = _compiled(tuple(sorted(paths.items())), n_objects)
    return copy.deepcopy(template)
