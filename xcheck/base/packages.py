"""An installed distribution's version, read from its metadata (nothing is imported for it)."""

from __future__ import annotations

from importlib import metadata

NOT_INSTALLED = "not installed"


def package_version(package: str) -> str:
    """The installed distribution's version, or :data:`NOT_INSTALLED`."""
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return NOT_INSTALLED
