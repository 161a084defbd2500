"""The simulators xcheck cross-checks. An engine is its module here, its entry in :data:`ENGINES` and its
runners in :mod:`xcheck.runners`: the module provides the simulation (``simulate`` -> ``Trajectory``) and may
provide ``bench_extras(contexts, dt, nsteps, repeat)`` (rows of its own for ``xcheck bench``: ``(method, scenario,
seconds, steps[, batch])``); the entry names
the distribution whose version every report records (:func:`xcheck.versions.versions`), the modules a worker
imports as it starts, whether a process working beside a pool leaves the engine's runs to the workers, and the
engine's own magnetometer where it has one."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Engine:
    name: str  # the runners' ``engine`` field, the prefix of their method names
    package: str  # the distribution whose version a report records
    module: str  # the module with ``simulate`` (imported only when the engine runs)
    top_level: str  # the package found (without importing it) to tell whether the engine is installed
    warm: tuple = ()  # what a worker imports as it starts, where the engine is available
    #: its import is costly (Basilisk's: 0.5 s a process) or its runs are long (PyBullet's, DART's, Drake's: 0.1-0.6
    #: s a method and study): a process that works beside a pool leaves its runs to the workers, which import it as
    #: they start and take them first (the longest tasks first balance the cores), and a study that runs them
    #: starts a worker for them
    to_workers: bool = False
    #: the engine's own magnetometer: ``(function in its module, what it is)``; the function gives the body-frame
    #: readings ``(model, q (n, 4), B_world (3,))`` of a field fixed in the world (the determination study reads
    #: it there); None: the engine has none wired here
    magnetometer: tuple[str, str] | None = None
    #: its methods join a study only when asked for (``$XCHECK_WITH``, ``xcheck report --with``, a scenario's or a
    #: command's ``methods``): MJX compiles each model, integrator and precision (1-3 s each), which would double
    #: every report where it is merely installed
    opt_in: bool = False
    #: the extra of ``pyproject.toml`` that installs it (default: the engine's name)
    extra: str = ""
    #: the steps one of its methods takes in a study at most, summed over the study's steps coarse to fine: its
    #: finest steps beyond are left out, and the report says so (:func:`xcheck.study.method_steps`); None: every
    #: step. For an engine that costs microseconds a step where ours cost a tenth of one: the report's speed goals
    step_budget: int | None = None
    #: the same in a quick study
    quick_step_budget: int | None = None
    #: its methods in a study run as one task, in one process: its import (0.1-0.4 s) is paid once, not by every
    #: process that would take one of them
    one_task: bool = False
    #: its step budget holds under a torque or on joints only: a free body's torque-free run is compiled end to end
    #: (EXUDYN's: 1-2.5 us a step), where a torque is a Python call at every stage and joints are constraints that
    #: its implicit solvers iterate on (0.05-0.2 ms a step)
    budget_under_torque: bool = False


#: The step budgets of the engines driven a step at a time (PyBullet, DART) or by Drake's Simulator (3-40 us a step,
#: where ours take 0.05-0.3): a full study of 10 s keeps its steps down to 1/512 s (20 + 40 + ... + 5 120 steps),
#: 0.05-0.4 s of one method's runs; a quick one its three coarsest (the least that shows an order). Measured
#: (speed.py, four engines): 25 000 / 12 000 made the full report 51 s and the quick 15.8; these 45.7 and 15.1.
_BUDGETS = {"step_budget": 12_000, "quick_step_budget": 6_000}
#: Drake's Simulator costs twice Bullet's and DART's step (5-12 us torque free, 15-35 with a torque at every stage):
#: 1/256 s and its three coarsest
_DRAKE_BUDGETS = {"step_budget": 6_000, "quick_step_budget": 3_000}
#: EXUDYN's six solvers, 19 us a stage each under a torque: a 10 s study keeps its steps down to 1/128 s (2 540 steps);
#: torque free, every step (1-2.5 us a step, as MuJoCo's)
_EXUDYN_BUDGETS = {"step_budget": 4_000, "quick_step_budget": 2_000}

ENGINES = {"mujoco": Engine("mujoco", "mujoco", "xcheck.engines.mujoco", "mujoco", warm=("xcheck.engines.mujoco",),
                            magnetometer=("magnetometer_readings", "MuJoCo's <magnetometer> sensor (uniform field, "
                                          "opt.magnetic = μ0 H) on MuJoCo's states")),
           "basilisk": Engine("basilisk", "bsk", "xcheck.engines.basilisk", "Basilisk",
                              warm=("xcheck.engines.basilisk", "Basilisk.simulation.spacecraft"), to_workers=True),
           "mjx": Engine("mjx", "mujoco-mjx", "xcheck.engines.mjx", "jax", opt_in=True),
           # PyBullet, DART and Drake: microseconds a step where ours take a tenth of one (a Python call a step; Drake's
           # Simulator): a step budget a method and study, their runs to the workers first (the longest tasks first)
           "pybullet": Engine("pybullet", "pybullet", "xcheck.engines.bullet", "pybullet",
                              warm=("xcheck.engines.bullet",), extra="engines", to_workers=True, one_task=True, **_BUDGETS),
           "dart": Engine("dart", "dartpy", "xcheck.engines.dart", "dartpy", warm=("xcheck.engines.dart",),
                          extra="engines", to_workers=True, one_task=True, **_BUDGETS),
           # EXUDYN: a C++ run of 1-2.5 us a step torque free, but a Python call at every stage under a torque (its
           # load's user function, 19 us a stage: 75 us a step of RK44, 170 of RK67)
           "exudyn": Engine("exudyn", "exudyn", "xcheck.engines.exu", "exudyn", warm=("xcheck.engines.exu",),
                            extra="engines", to_workers=True, one_task=True, budget_under_torque=True,
                            **_EXUDYN_BUDGETS),
           "drake": Engine("drake", "drake", "xcheck.engines.drake", "pydrake", warm=("xcheck.engines.drake",),
                           extra="engines", to_workers=True, one_task=True, **_DRAKE_BUDGETS)}


#: An optional engine is left out, although installed, when ``$XCHECK_WITHOUT`` names it (comma-separated):
#: ``XCHECK_WITHOUT=basilisk xcheck report`` is the report as on a machine without Basilisk (the speed figures
#: are measured both ways).
WITHOUT_VARIABLE = "XCHECK_WITHOUT"
#: An opt-in engine's methods join every study when ``$XCHECK_WITH`` names it (``xcheck report --with mjx``)
WITH_VARIABLE = "XCHECK_WITH"


def installed(engine: str) -> bool:
    """Whether an engine's package is installed (MuJoCo always is; Basilisk and MJX are the optional extras
    ``basilisk`` and ``mjx``), found without importing it: its top-level module and its distribution."""
    import importlib.metadata
    import importlib.util

    e = ENGINES[engine]
    if importlib.util.find_spec(e.top_level) is None:
        return False
    try:
        importlib.metadata.distribution(e.package)
    except importlib.metadata.PackageNotFoundError:
        return False
    return True


def asked_for(engine: str) -> bool:
    """Whether ``$XCHECK_WITH`` names an opt-in engine (its methods then join every study)."""
    import os

    return engine in {e.strip() for e in os.environ.get(WITH_VARIABLE, "").split(",")}


def left_out(engine: str) -> bool:
    """Whether ``$XCHECK_WITHOUT`` leaves an optional engine out (MuJoCo never is)."""
    import os

    return engine != "mujoco" and engine in {e.strip() for e in os.environ.get(WITHOUT_VARIABLE, "").split(",")}


def available(engine: str) -> bool:
    """Whether an engine runs here: installed and not left out."""
    return not left_out(engine) and installed(engine)


def warm_modules(engines=None) -> tuple:
    """What a worker imports as it starts for the engines available here (of ``engines`` alone, when given)."""
    chosen = [e for e in ENGINES.values() if available(e.name) and (engines is None or e.name in engines)]
    return tuple(m for engine in chosen for m in engine.warm)


#: engine name -> the distribution whose version a report records
ENGINE_PACKAGES = {name: engine.package for name, engine in ENGINES.items()}
