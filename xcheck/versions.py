"""Versions of everything a result depends on (recorded in every report and benchmark)."""

from __future__ import annotations

import os
import platform

from . import __version__
from .base.packages import NOT_INSTALLED, package_version  # noqa: F401 (NOT_INSTALLED: its home before issue 38)


#: What every result depends on besides xcheck itself and the engines.
CORE_PACKAGES = ("numpy", "scipy", "numba", "matplotlib")


_VERSIONS: dict = {}
#: engines installed but failing to import in this run: engine -> why (:func:`note_import_failure`)
_IMPORT_FAILURES: dict = {}


def note_import_failure(engine: str, why: str) -> None:
    """Record that ``engine`` is installed but fails to import here (a study found it): every versions line after
    names it with the reason."""
    _IMPORT_FAILURES[engine] = why


def versions() -> dict:
    """Versions of xcheck, every engine's package (:data:`xcheck.engines.ENGINE_PACKAGES`), numpy, scipy,
    numba, matplotlib and Python, read from the installed distributions (so that nothing imports an engine
    for it); an engine a study found failing to import is named with the reason. Read once per process (a study's result records them: 3 ms a time, the cost of a sweep's cell)."""
    from .engines import ENGINE_PACKAGES

    if not _VERSIONS:
        _VERSIONS.update({"xcheck": __version__, **{name: package_version(pkg) for name, pkg in ENGINE_PACKAGES.items()},
                          **{pkg: package_version(pkg) for pkg in CORE_PACKAGES}, "python": platform.python_version()})
    out = dict(_VERSIONS)
    for engine, why in _IMPORT_FAILURES.items():
        out[engine] = f"{out.get(engine)} (fails to import: {why})"
    return out


def machine() -> dict:
    return {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count()}
