"""The simulators xcheck cross-checks. An engine is its module here, its entry in :data:`ENGINES` and its
runners in :mod:`xcheck.runners`: the module provides the simulation (``simulate`` -> ``Trajectory``) and may
provide ``bench_extras(contexts, dt, nsteps, repeat)`` (rows of its own for ``xcheck bench``); the entry names
the distribution whose version every report records (:func:`xcheck.versions.versions`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Engine:
    name: str  # the runners' ``engine`` field, the prefix of their method names
    package: str  # the distribution whose version a report records
    module: str  # the module with ``simulate`` (imported only when the engine runs)


ENGINES = {"mujoco": Engine("mujoco", "mujoco", "xcheck.engines.mujoco"),
           "basilisk": Engine("basilisk", "bsk", "xcheck.engines.basilisk")}


#: An optional engine is left out, although installed, when ``$XCHECK_WITHOUT`` names it (comma-separated):
#: ``XCHECK_WITHOUT=basilisk xcheck report`` is the report as on a machine without Basilisk (the speed figures
#: are measured both ways).
WITHOUT_VARIABLE = "XCHECK_WITHOUT"


def available(engine: str) -> bool:
    """Whether an engine's package is installed (MuJoCo always is; Basilisk is the optional extra ``basilisk``),
    found without importing it, and not left out by ``$XCHECK_WITHOUT``."""
    import importlib.util
    import os

    if engine != "mujoco" and engine in {e.strip() for e in os.environ.get(WITHOUT_VARIABLE, "").split(",")}:
        return False
    return importlib.util.find_spec({"mujoco": "mujoco", "basilisk": "Basilisk"}[engine]) is not None
#: engine name -> the distribution whose version a report records
ENGINE_PACKAGES = {name: engine.package for name, engine in ENGINES.items()}
