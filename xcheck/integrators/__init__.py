"""Our own integrators: ``integrate`` (one trajectory) and ``integrate_batch`` (a leading batch axis).

>>> from xcheck.integrators import integrate, METHODS
>>> traj = integrate("lie-rkmk4", [0.005625, 0.0028125, 0.0028125], q0, omega0, dt=1/256, duration=10.0)

The fixed-step methods run in one compiled kernel (:mod:`.kernels`); with a Python torque callable the
same kernel source runs interpreted. Parallel runs use processes or :func:`integrate_batch` (threads inside
one compiled call), never Python threads over :func:`integrate`.
"""

from __future__ import annotations

import importlib.util
import sys
from dataclasses import dataclass

import numpy as np

from .. import rotations as rot
from ..base.interrupts import compiled_run_flag, raise_stopped
from ..body import validate_inertia
from ..fields import TorqueModel
from ..trajectory import (
    Trajectory,
    check_initial_state,
    step_plan,
    time_grid,
    tolerances_at,
)
from . import kernels
from .kernel_args import KernelArgs
from .methods import METHODS, Method

__all__ = ["integrate", "integrate_batch", "METHODS", "Method", "BatchResult", "SINGULAR_TOL", "precompile",
           "compile_cache_is_cold", "precompile_for_worker", "WORKER_PRECOMPILES"]

#: The kernels a worker compiles as it starts on a cold compile cache, while this process compiles the others: the
#: ones this process comes to last (it takes a study's methods from the back), compiled here first.
WORKER_PRECOMPILES = ("euler-rk4", "formulation-1", "formulation-2", "lie-rkmk4", "lie-cf4", "dcm-rk4", "gibbs-rk4")

#: An Euler-angle run stops when ``|det J|`` (``|sin|`` or ``|cos|`` of the middle angle) drops below this.
SINGULAR_TOL = 1e-10
#: Björck-Bowie stops when ``max |R^T R - I| <= BJORCK_TOL``.
BJORCK_TOL = 4.5 * np.finfo(float).eps

_twins: dict[str, object] = {}


def _kernels_for(*, python: bool = False):
    """The kernels for a run, the one place the variant is chosen: ``compiled`` (single trajectories and
    batches) or ``python`` (interpreted, for Python torque callables). The python variant is the same source
    package loaded under another name with ``VARIANT`` set on it before its modules run (see :mod:`.kernels`)."""
    variant = "python" if python else "compiled"
    if variant == "compiled":
        return kernels
    if variant not in _twins:
        name = f"{kernels.__name__}_{variant}"
        spec = importlib.util.spec_from_file_location(name, kernels.__file__,
                                                      submodule_search_locations=list(kernels.__path__))
        module = importlib.util.module_from_spec(spec)
        module.VARIANT = variant
        sys.modules[name] = module
        spec.loader.exec_module(module)
        _twins[variant] = module
    return _twins[variant]


def _method(name) -> Method:
    if isinstance(name, Method):  # a method made by hand (another tableau on a scheme: its stage loop is generated)
        return name
    if name not in METHODS:
        raise ValueError(f"method: unknown {name!r}; expected one of {', '.join(METHODS)}")
    return METHODS[name]


def _resolve_torque(torque, duration):
    """(kind or callable, P, T, python?) for the kernels."""
    if torque is None:
        return 0, np.zeros(3), np.zeros((0, 4)), False
    if isinstance(torque, TorqueModel):
        torque.check_span(duration)
        kind, P, T = torque.kernel_data()
        return kind, P, T, False
    if callable(torque):
        return torque, np.zeros(3), np.zeros((0, 4)), True
    raise ValueError(f"torque: expected None, a TorqueModel or a callable (t, q, omega) -> (3,), got "
                     f"{type(torque).__name__}")


def _kernel_args(info: Method, sequence: str, *, dt, n, last_h, torque, save_every) -> KernelArgs:
    A, b, c = info.tableau.arrays()
    tk, P, T = torque
    return KernelArgs(A=A, b=b, c=c, dt=float(dt), n=int(n), last_h=float(last_h), tk=tk, tP=P, tT=T,
                      axes=np.array(rot._check_seq(sequence), dtype=np.int64), sing_tol=SINGULAR_TOL,
                      bjorck_tol=BJORCK_TOL, save_every=int(save_every), stop=compiled_run_flag())


def _singular_message(info, sequence, y_last, t_stop):
    b = y_last[1]
    return (f"{info.name}: Euler sequence {sequence} reached its singularity at t = {t_stop:.6g} s "
            f"(middle angle {b:.6g} rad = {np.degrees(b):.6g} deg: the first and third rotation axes coincide); "
            "the trajectory ends at the last good step")


def integrate(method: str, inertia, q0, omega0, *, dt: float, duration: float, torque=None,
              sequence: str = "323", rtol: float | None = None) -> Trajectory:
    """Integrate rigid-body attitude motion with one of :data:`METHODS`.

    Parameters
    ----------
    method : str
        A key of :data:`METHODS`.
    inertia : array_like (3,) or (3, 3)
        Principal moments or the inertia tensor in body components [kg m^2].
    q0 : array_like (4,)
        Initial attitude [w, x, y, z], body -> world (normalised here).
    omega0 : array_like (3,)
        Initial body rate in body components [rad/s].
    dt, duration : float
        Step and total time [s]. The run ends exactly at ``duration``: if ``duration/dt`` is not an
        integer, the last step is shortened (see :func:`xcheck.trajectory.step_plan`).
    torque : None, TorqueModel or callable ``(t, q, omega) -> (3,)``
        Body-frame torque [N m], evaluated at every stage with the stage's time and state (``q``
        normalised). None: torque free. A :class:`~xcheck.fields.TorqueModel` runs compiled; any other
        callable runs the same kernel interpreted (slower).
    sequence : str
        Euler sequence of ``euler-rk4`` (default ``"323"``, seed 001's Z-Y-Z).
    rtol : float, optional
        An adaptive method's relative tolerance (its absolute tolerance keeps the method's own proportion; None:
        its defaults). ``dt`` is then its output step.

    Returns
    -------
    Trajectory
        ``t`` (n+1,), ``q`` (n+1, 4), ``omega`` (n+1, 3), ``status`` "ok" | "singular" | "failed";
        ``extras["evaluations"]``, the right-hand-side evaluations it took.
    """
    info = _method(method)
    I = validate_inertia(inertia)
    q0, omega0 = check_initial_state(q0, omega0)
    if q0.ndim != 1 or omega0.ndim != 1:
        raise ValueError("q0, omega0: integrate takes one trajectory; use integrate_batch for stacks")
    n, last_h = step_plan(dt, duration)
    rot._check_seq(sequence)
    tk, P, T, python = _resolve_torque(torque, duration)
    t = time_grid(n, float(dt), float(duration))
    if rtol is not None and not info.adaptive:
        raise ValueError(f"rtol: {method} is a fixed-step method; a tolerance applies to an adaptive one "
                         f"({', '.join(m.name for m in METHODS.values() if m.adaptive)})")
    if info.kernel is None:
        from .scipy_rk45 import integrate_scipy_rk45

        rel, abs_ = tolerances_at(rtol, info.tolerances)
        return integrate_scipy_rk45(I, q0, omega0, t, torque, float(dt), rtol=rel, atol=abs_)

    kern = _kernels_for(python=python)
    m = kern.STATE_SIZE[info.kernel]
    y0 = info.encode(q0, omega0, sequence)
    out = np.empty((n + 1, m))
    args = _kernel_args(info, sequence, dt=dt, n=n, last_h=last_h, torque=(tk, P, T), save_every=1)
    step = kern.step_of(info.kernel, info.tableau, info.dexp_A)  # made in the variant that runs it
    steps, status, work = kern.run_one(info.kernel, step, args, y0, I, np.linalg.inv(I), out)
    if status == kern.INTERRUPTED:
        raise_stopped()
    y = out[: steps + 1, :m]
    q, omega, extras = info.decode(y, sequence)
    extras["evaluations"] = info.stages * steps  # of the steps completed
    if info.kernel == kern.LGVI and work[kern.LGVI_WORK.split][0] > 0:
        split, most = (int(v) for v in work[kern.LGVI_WORK.split])
        extras["substeps"] = split
        extras["substeps_note"] = (
            f"{info.name}: {split} of its {steps} steps at dt = {float(dt):g} s taken as up to {most} substeps (its "
            "implicit equation has no solution where the step times the rate is more than 1 rad)")
    traj = Trajectory(t=t[: steps + 1], q=q, omega=omega, method=info.name, dt=float(dt), extras=extras)
    if status == kern.SINGULAR:
        traj.status = "singular"
        traj.message = _singular_message(info, sequence, y[-1], steps * float(dt))
    elif status == kern.NOT_CONVERGED:
        traj.status = "failed"
        traj.message = (f"{info.name}: the implicit step from t = {steps * float(dt):.6g} s has no solution, even as "
                        f"{kernels.LGVI_MOST_SUBSTEPS} substeps (Newton on the step's rotation did not converge); the "
                        "trajectory ends at the last good step")
    elif status == kern.NONFINITE:
        traj.status = "failed"
        traj.message = (f"{info.name}: blew up: the state became non-finite in the step from t = "
                        f"{steps * float(dt):.6g} s; the trajectory ends at the last good step")
    elif status == kern.OVER_BUDGET:
        traj.status = "failed"
        traj.message = (f"{info.name}: the step from t = {steps * float(dt):.6g} s turns the body by more than "
                        f"{kernels.MAX_TURN:g} rad (the exact free flow's budget of {kernels.MAX_PIECES} quadrature "
                        "pieces a step): take a shorter step; the trajectory ends at the last good step")
    return traj


@dataclass
class BatchResult:
    """Results of :func:`integrate_batch` for N trajectories.

    ``t`` (k,), ``q`` (N, k, 4) and ``omega`` (N, k, 3) hold the saved points (``save="all"``: every step,
    k = n + 1; ``save="final"``: k = 2, the initial and the final state); ``status`` (N,) of "ok" |
    "singular" | "failed"; ``steps_done`` (N,). A stopped trajectory's last saved point is its last
    good state.
    """

    t: np.ndarray
    q: np.ndarray
    omega: np.ndarray
    status: np.ndarray
    steps_done: np.ndarray


def integrate_batch(method: str, inertia, q0, omega0, *, dt: float, duration: float, torque=None,
                    sequence: str = "323", save: str = "final") -> BatchResult:
    """Integrate N trajectories at once (compiled, in parallel threads): ``q0`` (N, 4), ``omega0`` (N, 3);
    ``inertia`` (3,), (3, 3), (N, 3) or (N, 3, 3). Other arguments as :func:`integrate`.
    ``scipy-rk45`` is not a batch method."""
    info = _method(method)
    if info.kernel is None:
        raise ValueError(f"method: {method} has no batch path; use integrate()")
    q0, omega0 = check_initial_state(q0, omega0, batch=True)
    N = q0.shape[0]
    inertia = np.asarray(inertia, dtype=float)
    if inertia.shape in ((3,), (3, 3)):  # one body for all: one inverse
        I1 = validate_inertia(inertia)
        I, Iinv = (np.broadcast_to(M, (N, 3, 3)).copy() for M in (I1, np.linalg.inv(I1)))
    elif inertia.shape in ((N, 3), (N, 3, 3)):
        I = np.stack([validate_inertia(x, name=f"inertia[{i}]") for i, x in enumerate(inertia)])  # (per body)
        Iinv = np.linalg.inv(I)
    else:
        raise ValueError(f"inertia: expected (3,), (3, 3), ({N}, 3) or ({N}, 3, 3), got {inertia.shape}")
    if save not in ("final", "all"):
        raise ValueError(f"save: expected 'final' or 'all', got {save!r}")
    n, last_h = step_plan(dt, duration)
    rot._check_seq(sequence)
    tk, P, T, python = _resolve_torque(torque, duration)
    kern = _kernels_for(python=python)
    m = kern.STATE_SIZE[info.kernel]
    Y0 = np.ascontiguousarray(info.encode(q0, omega0, sequence))
    save_every = 1 if save == "all" else n
    rows = n + 1 if save == "all" else 2
    out = np.empty((N, rows, m))
    steps_done = np.zeros(N, dtype=np.int64)
    status = np.zeros(N, dtype=np.int64)
    args = _kernel_args(info, sequence, dt=dt, n=n, last_h=last_h, torque=(tk, P, T), save_every=save_every)
    step = kern.step_of(info.kernel, info.tableau, info.dexp_A)
    kern.run_many(info.kernel, step, args, Y0, I, Iinv, out, steps_done, status)
    if np.any(status == kern.INTERRUPTED):
        raise_stopped()
    y = out[:, :, :m].reshape(N * rows, m)
    q, omega, _ = info.decode(y, sequence)  # (sign continuity across trajectories is harmless)
    t = time_grid(n, float(dt), float(duration)) if save == "all" else np.array([0.0, float(duration)])
    names = np.array(["ok", "singular", "failed", "failed", "interrupted", "failed"])
    return BatchResult(t=t, q=q.reshape(N, rows, 4), omega=omega.reshape(N, rows, 3), status=names[status],
                       steps_done=steps_done)



def compile_cache_is_cold() -> bool:
    """Whether our integrators' compiled kernels are missing from the cache (a first run on this machine, or the
    first of a new release): none of the kernels' index files is there. False where the user keeps numba's own
    cache (``NUMBA_CACHE_DIR``), which xcheck does not look into."""
    from numba.core import config

    from .._jit import cache_root

    if config.CACHE_DIR:
        return False
    return not any((cache_root() / "integrators" / "kernels").glob("loops.run_*.nbi"))


def precompile(methods) -> None:
    """Compile (or load from the cache) the single-trajectory kernels of ``methods``: each run once for two steps,
    with a torque model, which gives the kernel the one signature every study's run has."""
    from ..fields import ConstantTorque

    torque = ConstantTorque([0.0, 0.0, 1e-6])
    for name in methods:
        if METHODS[name].kernel is not None:
            integrate(name, np.diag([1.0, 2.0, 3.0]), [1.0, 0.0, 0.0, 0.0], [0.1, 0.2, 0.3], dt=0.5, duration=1.0,
                      torque=torque)


def precompile_for_worker() -> None:
    """A worker's start on a cold compile cache (README line 1 on a new machine): it compiles
    :data:`WORKER_PRECOMPILES` while this process compiles the rest, as their studies come, instead of this process
    compiling every kernel alone (34 s of CPU for a full report) while the worker waits for Basilisk's runs. Nothing
    on a warm cache."""
    if compile_cache_is_cold():
        precompile(WORKER_PRECOMPILES)
