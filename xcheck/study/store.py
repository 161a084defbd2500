"""Finished studies kept by what was asked, for the processes of one test suite (issue 61: "compute each
expensive fixture once"). With ``XCHECK_STUDY_STORE`` naming a folder, :func:`~xcheck.study.run_study` reads a
study asked for before (in any process) instead of running it again; it and :func:`~xcheck.study.run_studies` (a
report's studies, all timed) keep each one they run. Unset (a user's run, and every process the suite starts but
the two that share), nothing is read or kept.

A study is known by everything that makes its numbers: the scenario as read (every field, the reference the guard
chose left out), its model file's bytes, the methods, the steps, the tolerances, whether it is quick, and this
xcheck's version. The code itself is not in the key: a store is for the processes of one run of the suite, whose
code does not change while it runs. A study run with its wall times repeated for figures (``timing``) serves a
request without; not the other way round.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import pickle
from pathlib import Path

ENV = "XCHECK_STUDY_STORE"


def _folder() -> Path | None:
    value = os.environ.get(ENV)
    return Path(value) if value else None


def study_key(scenario, methods, steps, tolerances, quick: bool) -> str | None:
    """The name a study is kept under (None: no store is set)."""
    if _folder() is None:
        return None
    from .. import __version__

    digest = hashlib.sha256(pickle.dumps((dataclasses.replace(scenario, guarded=None), tuple(methods),
                                          tuple(float(s) for s in steps), tuple(tolerances or ()), bool(quick),
                                          __version__)))
    model = getattr(scenario, "model", None)
    if model is not None and Path(model).is_file():
        digest.update(Path(model).read_bytes())
    return digest.hexdigest()


def stored(key: str | None, timing: bool):
    """The study kept under ``key``, or None (no store, none kept, or one without the wall times ``timing`` asks)."""
    if key is None:
        return None
    path = _folder() / f"{key}.pickle"
    try:
        kept_timing, study = pickle.loads(path.read_bytes())
    except FileNotFoundError:
        return None
    return study if kept_timing or not timing else None


def keep(key: str | None, study, timing: bool) -> None:
    """Keep ``study`` under ``key`` (:func:`~xcheck.base.files.write_bytes_atomic`: a reader sees all of it or
    nothing)."""
    if key is not None:
        from ..base.files import write_bytes_atomic

        write_bytes_atomic(_folder() / f"{key}.pickle", pickle.dumps((timing, study)))
