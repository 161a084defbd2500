"""Accuracy metrics: attitude and rate errors against a reference, conserved quantities, observed order."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import rotations as rot
from .body import validate_inertia
from .trajectory import Trajectory

__all__ = [
    "errors_against",
    "kinetic_energy",
    "world_momentum",
    "invariant_drift",
    "observed_order",
    "OrderFit",
    "ORDER_CEILING",
    "ORDER_FLOOR",
    "TOLERANCES",
    "tolerance_key",
    "StepWithin",
    "largest_step_within",
]

#: Errors above this [rad] are pre-asymptotic (beyond the small-error regime where e ~ C dt^p holds;
#: attitude errors also saturate at pi) and are not used to measure an order.
ORDER_CEILING = 0.1
#: Errors below this [rad] are not used to measure an order: the round-off of a 10 s run in double
#: precision reaches 1e-13 to 2e-11 rad here (it grows with the number of steps).
ORDER_FLOOR = 1e-12
#: The order is the median of this many finest local orders.
ORDER_POINTS = 3


def errors_against(traj: Trajectory, q_ref: np.ndarray, omega_ref: np.ndarray) -> dict:
    """Errors of ``traj`` against reference values at the same times ``(n, 4)``, ``(n, 3)``.

    Returns ``attitude_error`` (geodesic angle at the final time [rad]), ``max_attitude_error`` (over the
    grid), ``omega_error`` and ``max_omega_error`` (Euclidean norm [rad/s]).
    """
    att = rot.attitude_error(traj.q, q_ref)
    om = np.linalg.norm(traj.omega - omega_ref, axis=-1)
    return {"attitude_error": float(att[-1]), "max_attitude_error": float(att.max()),
            "omega_error": float(om[-1]), "max_omega_error": float(om.max())}


def kinetic_energy(inertia, omega) -> np.ndarray:
    """``1/2 w.I w`` [J] for body rates ``(..., 3)``."""
    I = validate_inertia(inertia)
    omega = np.asarray(omega, dtype=float)
    return 0.5 * np.einsum("...i,ij,...j->...", omega, I, omega)


def world_momentum(inertia, q, omega) -> np.ndarray:
    """Angular momentum in world components ``R(q) I w`` [kg m^2/s], ``(..., 3)``."""
    I = validate_inertia(inertia)
    return rot.quat_rotate(q, np.asarray(omega, dtype=float) @ I.T)


def invariant_drift(inertia, traj: Trajectory) -> dict:
    """Relative drift of the invariants over a trajectory (max over the grid).

    ``energy_drift`` = max |E - E0| / E0 and ``momentum_drift`` = max |H - H0| / |H0| (conserved when
    torque free), ``norm_drift`` = max ||q| - 1| (of the stored quaternion), and for DCM runs
    ``orthogonality_drift`` = max |R^T R - I|.
    """
    E = kinetic_energy(inertia, traj.omega)
    H = world_momentum(inertia, traj.q, traj.omega)
    E0, H0 = E[0], np.linalg.norm(H[0])
    out = {
        "energy_drift": float(np.max(np.abs(E - E0)) / E0) if E0 > 0 else 0.0,
        "momentum_drift": float(np.max(np.linalg.norm(H - H[0], axis=-1)) / H0) if H0 > 0 else 0.0,
        "norm_drift": float(np.max(np.abs(np.linalg.norm(traj.q, axis=-1) - 1.0))),
    }
    if "orthogonality" in traj.extras:
        out["orthogonality_drift"] = float(np.max(traj.extras["orthogonality"]))
    return out


@dataclass
class OrderFit:
    """The observed order of a step sweep and how it was measured."""

    order: float | None
    used: list  # the dt values used
    local_orders: list  # log(e_i / e_i+1) / log(dt_i / dt_i+1) between consecutive used steps
    note: str


def observed_order(dts, errors, *, ceiling: float = ORDER_CEILING, floor: float = ORDER_FLOOR,
                   points: int = ORDER_POINTS) -> OrderFit:
    """Observed order of convergence of a step sweep.

    The rule, on the steps ordered from coarse to fine:

    1. round-off: the steps after the smallest error are dropped (there the error grows again as the
       steps multiply), and so are errors below ``floor`` (:data:`ORDER_FLOOR`, or a study's own floor
       that also covers its reference's accuracy);
    2. pre-asymptotic: errors above ``ceiling`` are dropped (beyond the small-error regime; attitude
       errors also saturate at pi);
    3. the local orders ``log(e_i/e_i+1) / log(dt_i/dt_i+1)`` of consecutive remaining steps are formed,
       and the order is the median of the ``points`` finest ones: the median is not moved by one odd
       pair (a chart switch, the last pre-asymptotic wiggle). With no pair, it is None.
    """
    dts = np.asarray(dts, dtype=float)
    errors = np.asarray([np.nan if e is None else e for e in errors], dtype=float)
    order = np.argsort(dts)[::-1]
    dts, errors = dts[order], errors[order]
    finite = np.isfinite(errors)
    if not np.any(finite):
        return OrderFit(None, [], [], "no run completed: no order measured")
    smallest = int(np.nanargmin(np.where(finite, errors, np.nan)))
    ok = finite & (np.arange(len(errors)) <= smallest) & (errors >= floor) & (errors <= ceiling)
    used_dt, used_e = dts[ok], errors[ok]
    local = [float(np.log(used_e[i] / used_e[i + 1]) / np.log(used_dt[i] / used_dt[i + 1]))
             for i in range(len(used_dt) - 1)]
    if not local:
        return OrderFit(None, used_dt.tolist(), local,
                        f"fewer than two steps with decreasing errors in [{floor:.2g}, {ceiling:g}] rad: no order "
                        "measured")
    finest = local[-points:]
    return OrderFit(float(np.median(finest)), used_dt.tolist(), local,
                    f"median of the local orders between dt = {used_dt[-len(finest) - 1]:.4g} and {used_dt[-1]:.4g} s")


# ------------------------------------------------------------------------------------------------
# what a tolerance costs
# ------------------------------------------------------------------------------------------------
#: The attitude tolerances [rad] of the step-size table (JSON keys ``tolerance_key``: "1e-03", ...).
TOLERANCES = (1e-3, 1e-6, 1e-9)


def tolerance_key(tol: float) -> str:
    """``1e-06`` for 1e-6: the JSON key of a tolerance."""
    return f"{tol:.0e}"


@dataclass
class StepWithin:
    """The largest step [s] at which a method stays within a tolerance over the run, and the wall time [s] a
    run at that step costs. ``how``: ``"interpolated"`` (on the log-log line between the two tested steps that
    bracket the tolerance), ``"tested"`` (the coarsest tested step is within: a larger one may be too) or
    ``"none"`` (not even the finest tested step is; ``dt`` and ``wall_time`` are None). For an adaptive method
    the same of its own relative tolerance: ``rtol`` the loosest that keeps the run within (``dt`` None)."""

    dt: float | None
    wall_time: float | None
    how: str
    rtol: float | None = None

    @property
    def reached(self) -> bool:
        return self.how != "none"

    def to_json(self) -> dict:
        return {"dt": self.dt, "wall_time": self.wall_time, "how": self.how,
                **({"rtol": self.rtol} if self.rtol is not None else {})}


def largest_step_within(dts, errors, wall_times, tol: float) -> StepWithin:
    """The largest step at which the error stays within ``tol`` (see :class:`StepWithin`).

    On the steps from fine to coarse (a failed run, ``None`` error, counts as outside), the steps are within
    up to the first one that is not; between that one (``dt_a``, ``e_a > tol``) and the last within (``dt_b``,
    ``e_b <= tol``) the error is taken as a power of the step, ``log e`` linear in ``log dt`` (exact for a
    method in its asymptotic range), and solved for ``e = tol``; the wall time likewise (it goes as
    ``1/dt``). The errors should be maxima over the run (the tolerance holds over the whole duration)."""
    rows = sorted(zip(dts, errors, wall_times), key=lambda r: r[0])
    if not rows or rows[0][1] is None or not rows[0][1] <= tol:
        return StepWithin(None, None, "none")
    k = 0
    while k + 1 < len(rows) and rows[k + 1][1] is not None and rows[k + 1][1] <= tol:
        k += 1
    dt_b, e_b, w_b = rows[k]
    if k + 1 == len(rows) or rows[k + 1][1] is None or not np.isfinite(rows[k + 1][1]) or e_b <= 0:
        return StepWithin(float(dt_b), None if w_b is None else float(w_b), "tested")
    dt_a, e_a, w_a = rows[k + 1]
    s = (np.log(tol) - np.log(e_b)) / (np.log(e_a) - np.log(e_b))  # 0 at dt_b, 1 at dt_a
    dt = float(np.exp(np.log(dt_b) + s * (np.log(dt_a) - np.log(dt_b))))
    wall = None
    if w_a and w_b:
        wall = float(np.exp(np.log(w_b) + s * (np.log(w_a) - np.log(w_b))))
    return StepWithin(dt, wall, "interpolated")
