"""Where the bundled files are, and what a file given as a scenario or a model is (an XML root, a URDF), without
importing anything heavy: reading a scenario, listing the bundled ones and collecting pytest items need these, not
MuJoCo."""

from __future__ import annotations

from pathlib import Path

__all__ = ["BUNDLED_MODELS", "xml_root", "foreign_model", "FOREIGN_MODELS"]


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
    path = Path(str(path).partition("#")[0])
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
