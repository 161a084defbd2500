"""Where the bundled files are, without importing anything heavy: reading a scenario, listing the bundled ones and
collecting pytest items need the folder, not MuJoCo."""

from __future__ import annotations

from pathlib import Path

__all__ = ["BUNDLED_MODELS"]


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
