"""``xcheck league``: the boxes benchmark run by MuJoCo's four integrators (translation and all, as the benchmark's
engines ran it) and by our fixed-step methods (attitude only, the centre of mass the exact parabola), every case at
every step, with the benchmark's metrics (:mod:`xcheck.league.boxes`) and our own: the attitude error at the end
against the exact reference. The rows sit beside the published ones in :mod:`xcheck.league.table`."""

from __future__ import annotations

import time

import numpy as np

from ..integrators import integrate
from ..integrators.methods import METHODS
from ..paths import BUNDLED_MODELS
from ..reference import exact_torque_free
from ..rotations import attitude_error
from . import boxes as B

MUJOCO_INTEGRATORS = ("euler", "implicit", "implicitfast", "rk4")
#: Our fixed-step methods in the table (the demonstrations of a seed's misprint left out)
OURS = tuple(name for name, m in METHODS.items() if m.kernel is not None and m.demonstration is None)
#: Euler-angle sequences clear of their singularity for each case's motion (3-2-3 starts at it)
SEQUENCE = {"simple": "123", "complex": "213"}
#: The steps of a quick table and of the report's section: the benchmark's coarsest, where the engines differ most
QUICK_STEPS = (1e-3,)
#: The full report's: the benchmark's two coarsest (1e-4 s, ten times the runs, is xcheck league's: docs/league.md)
REPORT_STEPS = (5e-4, 1e-3)


def box_model() -> str:
    return str(BUNDLED_MODELS / "box.xml")


def _rows(case_name: str, engine: str, method: str, steps, fly) -> list[dict]:
    """One method on one case at each step: ``fly(case, dt, n) -> (t, q, omega, c, v)`` (``c``, ``v`` None for an
    attitude-only run, whose centre of mass is the exact parabola); the benchmark's errors and the attitude error at
    the end against the exact solution."""
    case = B.CASES[case_name]
    rows = []
    for dt in steps:
        n = B.step_count(dt)
        start = time.perf_counter()
        t, q, w, c, v = fly(case, dt, n)
        wall = time.perf_counter() - start
        position, velocity = (None, None) if c is None else B.translation_errors(case, t, c, v)
        q_exact, _ = exact_torque_free(B.INERTIA, [1.0, 0, 0, 0], case.omega0, np.array([0.0, t[-1]]))
        rows.append({"case": case.name, "engine": engine, "method": method, "dt": dt, "steps": n, "sim_time": n * dt,
                     "wall_time": wall, "momentum_error": B.angular_momentum_error(q, w),
                     "energy_error": B.energy_error(case, w, c, v, t), "position_error": position,
                     "velocity_error": velocity, "attitude_error": float(attitude_error(q[-1], q_exact[-1]))})
    return rows


def mujoco_rows(case_name: str, integrator: str, steps=B.STEPS) -> list[dict]:
    """MuJoCo's ``integrator`` on one case at each step, flying the whole body (translation and gravity included)."""
    from ..engines.mujoco import free_flight

    def fly(case, dt, n):
        t, c, q, v, w = free_flight(box_model(), integrator=integrator, omega0=case.omega0, v0=case.v0,
                                    gravity=case.gravity, dt=dt, nsteps=n)
        return t, q, w, c, v
    return _rows(case_name, "mujoco", f"mujoco-{integrator}", steps, fly)


def bullet_rows(case_name: str, path: str, steps=B.STEPS) -> list[dict]:
    """PyBullet's ``path`` on one case at each step, flying the whole body (issue 40: the benchmark's Bullet, live);
    ``multibody-default`` is the multibody with PyBullet's default angular damping (0.04), as a user's first try
    meets it."""
    from ..engines.bullet import DEFAULT_ANGULAR_DAMPING, free_flight

    bullet_path, damping = ("multibody", DEFAULT_ANGULAR_DAMPING) if path == "multibody-default" else (path, 0.0)

    def fly(case, dt, n):
        t, c, q, v, w = free_flight(path=bullet_path, mass=B.MASS, moments=B.INERTIA, omega0=case.omega0,
                                    v0=case.v0, gravity=case.gravity, dt=dt, nsteps=n, angular_damping=damping)
        return t, q, w, c, v
    return _rows(case_name, "pybullet", f"pybullet-{path}", steps, fly)


def dart_rows(case_name: str, steps=B.STEPS) -> list[dict]:
    """DART on one case at each step, flying the whole body (issue 40: the benchmark's DART, live)."""
    from ..engines.dart import free_flight

    def fly(case, dt, n):
        t, c, q, v, w = free_flight(mass=B.MASS, moments=B.INERTIA, omega0=case.omega0, v0=case.v0,
                                    gravity=case.gravity, dt=dt, nsteps=n)
        return t, q, w, c, v
    return _rows(case_name, "dart", "dart-semi-implicit-euler", steps, fly)


def drake_rows(case_name: str, integrator: str, steps=B.STEPS) -> list[dict]:
    """Drake's ``integrator`` on one case at each step, flying the whole body (issue 40: Drake, live; it was not in
    the 2015 benchmark)."""
    from ..engines.drake import free_flight

    def fly(case, dt, n):
        t, c, q, v, w = free_flight(integrator=integrator, mass=B.MASS, moments=B.INERTIA, omega0=case.omega0,
                                    v0=case.v0, gravity=case.gravity, dt=dt, nsteps=n)
        return t, q, w, c, v
    return _rows(case_name, "drake", f"drake-{integrator}", steps, fly)


def exudyn_rows(case_name: str, integrator: str, steps=B.STEPS) -> list[dict]:
    """EXUDYN's ``integrator`` on one case at each step, flying the whole body on its Lie group node (issue 40:
    EXUDYN, live; it was not in the 2015 benchmark)."""
    from ..engines.exu import free_flight

    def fly(case, dt, n):
        t, c, q, v, w = free_flight(integrator=integrator, mass=B.MASS, moments=B.INERTIA, omega0=case.omega0,
                                    v0=case.v0, gravity=case.gravity, dt=dt, nsteps=n)
        return t, q, w, c, v
    return _rows(case_name, "exudyn", f"exudyn-{integrator}", steps, fly)


#: PyBullet's rows in the league: its two paths, and the multibody as PyBullet makes it (its default damping on)
BULLET_PATHS = ("multibody", "maximal", "multibody-default")
#: Drake's rows: its semi-explicit Euler (the benchmark's engines' kind of step) and its third-order Runge-Kutta
DRAKE_INTEGRATORS = ("semi-explicit-euler", "rk3")
#: EXUDYN's rows: its Lie group RK44 (RKMK4) and its implicit generalized-alpha
EXUDYN_INTEGRATORS = ("rk44", "generalized-alpha")
#: The engine whose module each row function imports (a broken install is named, its rows left out)
ROW_ENGINES = {"mujoco_rows": "mujoco", "bullet_rows": "pybullet", "dart_rows": "dart", "drake_rows": "drake",
               "exudyn_rows": "exudyn"}


def our_rows(case_name: str, method: str, steps=B.STEPS) -> list[dict]:
    """One of our methods on one case at each step (attitude only: no translation errors of its own)."""
    def fly(case, dt, n):
        traj = integrate(method, B.INERTIA, [1.0, 0, 0, 0], case.omega0, dt=dt, duration=n * dt,
                         sequence=SEQUENCE[case_name])
        if traj.status != "ok":
            raise RuntimeError(f"{method} on the boxes' {case_name} case at dt = {dt:g} s: {traj.message}")
        return traj.t, traj.q, traj.omega, None, None
    return _rows(case_name, "xcheck", method, steps, fly)


def league_tasks(cases=tuple(B.CASES), steps=B.STEPS) -> list[tuple]:
    """``(function, case, method, steps)`` for every method on every case: MuJoCo's first (its runs are the longest)."""
    from ..engines import available

    return ([(mujoco_rows, c, i, tuple(steps)) for c in cases for i in MUJOCO_INTEGRATORS]
            + [(bullet_rows, c, path, tuple(steps)) for c in cases for path in BULLET_PATHS
               if available("pybullet")]
            + [(dart_rows, c, tuple(steps)) for c in cases if available("dart")]
            + [(drake_rows, c, i, tuple(steps)) for c in cases for i in DRAKE_INTEGRATORS if available("drake")]
            + [(exudyn_rows, c, i, tuple(steps)) for c in cases for i in EXUDYN_INTEGRATORS if available("exudyn")]
            + [(our_rows, c, m, tuple(steps)) for c in cases for m in OURS])


def run_league(steps=B.STEPS, *, pool=None, progress=None) -> list[dict]:
    """Every row of the league at ``steps``: in ``pool`` (an executor) when given, else here."""
    tasks = league_tasks(steps=steps)
    rows = []
    if pool is None:
        for k, (fn, *args) in enumerate(tasks):
            rows += _rows_of(fn, lambda: fn(*args))
            if progress:
                progress(k + 1, len(tasks), f"{args[0]} {args[1]}")
    else:
        futures = [(fn, pool.submit(fn, *args)) for fn, *args in tasks]
        for k, (fn, f) in enumerate(futures):
            rows += _rows_of(fn, f.result)
            if progress:
                progress(k + 1, len(tasks), "")
    return rows


def _rows_of(fn, get) -> list[dict]:
    """``get()``'s rows, or none where the row function's engine is installed but fails to import here (named, with
    the reason, in every versions line after: :func:`xcheck.versions.note_import_failure`)."""
    try:
        return get()
    except ImportError as exc:
        engine = ROW_ENGINES.get(fn.__name__)
        if engine in (None, "mujoco"):
            raise
        from ..versions import note_import_failure

        note_import_failure(engine, f"{type(exc).__name__}: {exc}")
        return []
