"""numba for xcheck, with the compiled-code cache kept out of the installed package.

By default numba caches compiled functions beside their source, in ``__pycache__`` folders inside
``site-packages/xcheck``. ``pip`` does not know those files: an uninstall leaves them, and the leftover
``xcheck/`` folder (no ``__init__.py``) then shadows a later editable install (issue 8). Every xcheck function
compiled with ``cache=True`` is therefore cached in a per-user folder instead:

    ``$XCHECK_CACHE_DIR``, else ``$XDG_CACHE_HOME/xcheck``, else ``~/.cache/xcheck``,
    then ``numba-<xcheck version>-<hash of the compiled sources>-generic/<the source's folder in the package>``.

The code is compiled for the architecture's generic CPU (``-generic``; without that suffix where the process compiles
for its own CPU): the same code on every machine, which lets a release ship it and a first run unpack it there instead
of compiling (:mod:`xcheck._prebuilt`).

The hash covers every compiled source file (:data:`COMPILED_SOURCES`) together, because the kernels compile
the torque code of ``fields/kernel.py`` into themselves and numba checks only a function's own file. A checkout and an
installed copy of the same release share the folder (numba's own stamp is the file's content). A user who sets
``NUMBA_CACHE_DIR`` or ``NUMBA_CACHE_LOCATOR_CLASSES`` keeps numba's own behaviour. Functions outside xcheck
are not affected.

Import numba's decorators from here (``from ._jit import njit``) so that the locator is in place before the
first ``cache=True`` function is defined.
"""

from __future__ import annotations

import hashlib
import os
from functools import lru_cache
from pathlib import Path

import numba
from numba import njit, prange  # noqa: F401  (re-exported)
from numba.extending import intrinsic
from numba.core import caching, config

from . import __version__, _prebuilt

__all__ = ["njit", "prange", "numba", "cache_root", "user_cache_home", "compiled_code_loaded", "COMPILED_SOURCES",
           "stop_requested", "GENERIC", "sources_digest"]

PACKAGE = Path(__file__).resolve().parent
#: The package files with ``cache=True`` functions, relative to the package folder.
COMPILED_SOURCES = ("_jit.py", "fields/kernel.py",
                    *(f"integrators/kernels/{f}.py" for f in ("_variant", "registry", "helpers", "freeflow", "schemes",
                                                              "lanes", "steps", "loops")),
                    "integrators/dop853.py", "determination/methods.py", "engines/held_input.py", "metrics.py")


def user_cache_home() -> Path:
    if os.environ.get("XCHECK_CACHE_DIR"):
        return Path(os.environ["XCHECK_CACHE_DIR"]).expanduser()
    if os.environ.get("XDG_CACHE_HOME"):
        return Path(os.environ["XDG_CACHE_HOME"]).expanduser() / "xcheck"
    if os.name == "nt" and os.environ.get("LOCALAPPDATA"):
        return Path(os.environ["LOCALAPPDATA"]) / "xcheck" / "cache"
    return Path.home() / ".cache" / "xcheck"


def _context_made() -> bool:
    from numba.core.registry import cpu_target

    return vars(cpu_target).get("_toplevel_target_context") is not None


#: Whether this process compiles for the generic CPU (:mod:`xcheck._prebuilt`): set here, before numba makes its CPU
#: context (at the first compiled function's declaration), which reads the CPU it compiles for once per process.
GENERIC = _prebuilt.choose_target(config, _context_made())


@lru_cache(maxsize=1)
def sources_digest() -> str:
    """12 hex digits of the SHA-256 of the compiled sources, :data:`COMPILED_SOURCES`, together."""
    digest = hashlib.sha256()
    for rel in COMPILED_SOURCES:
        digest.update((PACKAGE / rel).read_bytes())
    return digest.hexdigest()[:12]


@lru_cache(maxsize=1)
def cache_root() -> Path:
    """The folder of this release's compiled code (see the module docstring); a new one is first unpacked from the
    shipped archive where one fits (:mod:`xcheck._prebuilt`)."""
    root = user_cache_home() / f"numba-{__version__}-{sources_digest()}{'-' + _prebuilt.TARGET if GENERIC else ''}"
    if GENERIC and not root.exists():
        archive = _prebuilt.archive_for(root.name, numba.__version__)
        if archive is not None:
            _prebuilt.unpack(archive, root)
    return root


class XcheckCacheLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
    """numba cache locator for xcheck's own source files only (others: ``from_function`` returns None)."""

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        rel = Path(py_file).resolve().parent.relative_to(PACKAGE)
        self._cache_path = str(cache_root() / rel)

    def get_cache_path(self):
        return self._cache_path

    @classmethod
    def from_function(cls, py_func, py_file):
        if config.CACHE_DIR:  # the user's NUMBA_CACHE_DIR wins
            return None
        try:
            Path(py_file).resolve().relative_to(PACKAGE)
        except ValueError:
            return None
        # the mixin checks that the file exists and that the folder can be created and written; None if not
        return super().from_function(py_func, py_file)


def compiled_code_loaded() -> bool:
    """Whether this process has loaded compiled code yet. numba's first compiled function of a process builds
    its CPU context first (0.3-0.5 s: the registries of every numpy and math implementation); a process that
    only drives another engine (Basilisk's worker) need never pay it, where the same result is numpy's for a
    few milliseconds more (:func:`xcheck.metrics.errors_against`). False also if numba ever keeps that state
    elsewhere: numpy's way is then taken everywhere, with the same numbers."""
    from numba.core.registry import cpu_target

    context = vars(cpu_target).get("_toplevel_target_context")  # made as a compiled function is declared
    return bool(getattr(context, "_registries", None))  # filled as the first one is compiled or loaded


def _install() -> None:
    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
    if XcheckCacheLocator not in impl._locator_classes:
        impl._locator_classes = [XcheckCacheLocator, *impl._locator_classes]


_install()


@intrinsic
def _load_flag(typingctx, flag):
    """``flag[0]`` read as an atomic (monotonic) load: the compiler keeps it inside the loop that polls it (a plain
    load of an array the loop never writes may be hoisted out of it, and the loop would never see the flag set)."""
    if not (isinstance(flag, numba.types.Array) and flag.dtype == numba.types.int64):
        return None

    def codegen(context, builder, signature, args):
        array = context.make_array(signature.args[0])(context, builder, args[0])
        return builder.load_atomic(array.data, "monotonic", 8)

    return numba.types.int64(flag), codegen


@njit(cache=True, inline="always", _nrt=False)
def stop_requested(flag):
    """Whether a stop was asked for (:func:`xcheck.base.interrupts.stop_flag`): the poll of every long compiled loop."""
    return _load_flag(flag) != 0
