"""Versions of everything a result depends on (recorded in every report and benchmark)."""

from __future__ import annotations

import os
import platform
from importlib import metadata

from . import __version__


def _version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "not installed"


def versions() -> dict:
    """xcheck, mujoco, numpy, scipy, numba, matplotlib and Python versions (read from the installed
    distributions, so that the core never imports mujoco for it)."""
    return {"xcheck": __version__, "mujoco": _version("mujoco"), "numpy": _version("numpy"),
            "scipy": _version("scipy"), "numba": _version("numba"), "matplotlib": _version("matplotlib"),
            "python": platform.python_version()}


def machine() -> dict:
    return {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count()}
