"""Where the bundled files are, and what a file given as a scenario or a model is (an XML root, a URDF), without
importing anything heavy: reading a scenario, listing the bundled ones and collecting pytest items need these, not
MuJoCo."""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

__all__ = ["BUNDLED_MODELS", "xml_root", "foreign_model", "FOREIGN_MODELS", "MAX_INPUT_BYTES", "input_problem"]

#: The largest input file xcheck reads [bytes]: a scenario, a sweep spec, an MJCF model, a field table. The bundled
#: ones are under 0.1 MB and an MJCF of 10 000 geoms is 1 MB; a larger file is a slip (a log, a disk image, /dev/zero
#: through a link) that would otherwise be read whole into memory.
MAX_INPUT_BYTES = 64 * 2**20


def input_problem(path, what: str = "file", *, limit: int = MAX_INPUT_BYTES) -> str | None:
    """Why ``path`` cannot be read as an input ``what`` (a scenario, an MJCF model, ...) — missing, a symlink loop, a
    folder, not a regular file (a FIFO would block the reader forever, a device never end), larger than ``limit`` —
    as ``"PATH: reason"``, or None where it can. Only the file's metadata is looked at."""
    a = "an" if what[:1] in "aeiouM" else "a"  # (an MJCF file)
    try:
        st = os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return f"{path}: a loop of symbolic links, not {a} {what}"
        if exc.errno == errno.ENOENT:
            return f"{path}: no such {what}"
        return f"{path}: cannot read the {what} ({exc.strerror})"
    if stat.S_ISDIR(st.st_mode):
        return f"{path}: a folder, not {a} {what}"
    if not stat.S_ISREG(st.st_mode):
        kind = "a FIFO" if stat.S_ISFIFO(st.st_mode) else "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(
            st.st_mode) else "a socket" if stat.S_ISSOCK(st.st_mode) else "not a regular file"
        return f"{path}: {kind}, not {a} {what} (xcheck reads regular files)"
    if st.st_size > limit:
        return (f"{path}: {st.st_size:,} bytes, more than the {limit // 2**20} MB {a} {what} may have (the bundled ones "
                "are under 0.1 MB): not read")
    return None


def _bundled_folder() -> Path:
    """The bundled models: the repository's top-level ``models/`` in a checkout, or the copy installed
    with the package as ``xcheck/bundled``."""
    here = Path(__file__).resolve().parent
    for folder in (here.parent / "models", here / "bundled"):
        if (folder / "scenarios").is_dir():
            return folder
    return here / "bundled"


#: The folder of the bundled models, scenarios and sweeps.
BUNDLED_MODELS = _bundled_folder()


def xml_root(path) -> str | None:
    """The root element's name of an XML file (``mujoco`` for MJCF, ``robot`` for URDF), or None where it is no XML
    file that can be read (its reader then says why)."""
    import xml.etree.ElementTree as ET

    try:
        for _, element in ET.iterparse(path, events=("start",)):
            return element.tag
    except (ET.ParseError, OSError):
        return None
    return None


#: Model formats xcheck does not read, by file ending: what they are, and how MuJoCo makes MJCF of them.
FOREIGN_MODELS = {".urdf": "a URDF robot description", ".sdf": "an SDF (Gazebo) model", ".mjb": "a compiled MuJoCo model",
                  ".usd": "a USD scene", ".usda": "a USD scene", ".dae": "a COLLADA mesh", ".stl": "a mesh",
                  ".obj": "a mesh"}
_TO_MJCF = ("xcheck reads MJCF (.xml); MuJoCo converts a URDF: m = mujoco.MjModel.from_xml_path('robot.urdf'); "
            "mujoco.mj_saveLastXML('robot.xml', m), then give the body a <freejoint/>")


def foreign_model(path) -> str | None:
    """Why ``path`` (given where a scenario goes) is a model xcheck does not read — a URDF, an SDF, a compiled or
    mesh file, by its ending or, for an XML file, its root element — or None."""
    text = str(path)
    path = Path(text if Path(text).suffix or "#" not in text else text.rpartition("#")[0])
    suffix = path.suffix.lower()
    if suffix in FOREIGN_MODELS:
        what = FOREIGN_MODELS[suffix]
    elif suffix in ("", ".xml") or not path.is_file():
        return None
    else:  # another ending (a .toml that is XML): by its root element
        root = xml_root(path)
        if root is None:
            return None
        what = "a URDF robot description" if root == "robot" else f"an XML file (<{root}>)"
    return f"{path}: {what}, not an MJCF model nor a scenario file: {_TO_MJCF}"
