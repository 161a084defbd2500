"""Accuracy metrics: attitude and rate errors against a reference, the invariants' signed changes, observed order."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import rotations as rot
from ._jit import compiled_code_loaded, njit
from .body import validate_inertia
from .invariants import invariant_series, largest_change
from .trajectory import Trajectory, same_step

__all__ = [
    "errors_against",
    "kinetic_energy",
    "world_momentum",
    "invariant_changes",
    "observed_order",
    "ladder_steps",
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
#: Where a method's error rose again after its smallest (its own round-off), errors within this factor of that smallest
#: are round-off too, not its truncation error (:func:`observed_order`)
ROUNDOFF_BAND = 10.0
#: A rise of the error between steps below this [rad] is round-off (a pre-asymptotic wiggle is larger)
ROUNDOFF_SCALE = 1e-8


def errors_against(traj: Trajectory, q_ref: np.ndarray, omega_ref: np.ndarray) -> dict:
    """Errors of ``traj`` against reference values at the same times ``(n, 4)``, ``(n, 3)``.

    Returns ``attitude_error`` (geodesic angle at the final time [rad]), ``max_attitude_error`` (over the
    grid), ``omega_error`` and ``max_omega_error`` (Euclidean norm [rad/s]). The angle is
    :func:`xcheck.rotations.attitude_error`'s, computed in one compiled pass with the same operations in the same
    order (bit for bit the same numbers; numpy's dozen calls over the arrays cost 6x more, and a study makes one
    call a run)."""
    q, w, q_ref, omega_ref = (_rows(a, k) for a, k in ((traj.q, 4), (traj.omega, 3), (q_ref, 4), (omega_ref, 3)))
    if not len(q) == len(w) == len(q_ref) == len(omega_ref) > 0:
        raise ValueError(f"errors_against: expected as many (and some) states as reference values, got {len(q)} "
                         f"quaternions, {len(w)} rates, {len(q_ref)} and {len(omega_ref)} reference values")
    if not compiled_code_loaded():  # numpy's statement of the same operations (see compiled_code_loaded)
        att = rot.attitude_error(q, q_ref)
        om = np.linalg.norm(w - omega_ref, axis=-1)
        out = (att[-1], np.max(att), om[-1], np.max(om))
    else:
        out = np.empty(4)
        _errors(q, w, q_ref, omega_ref, out)
    return {"attitude_error": float(out[0]), "max_attitude_error": float(out[1]),
            "omega_error": float(out[2]), "max_omega_error": float(out[3])}


def _rows(a, k: int) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=float)
    if a.ndim != 2 or a.shape[1] != k:
        raise ValueError(f"expected an (n, {k}) array, got shape {a.shape}")
    return a


@njit(cache=True, error_model="numpy", inline="always")
def _unit(a, b, c, d):
    """``rotations._unit_quat`` for one quaternion: scaled by its largest component, then by its norm."""
    s = max(abs(a), abs(b), abs(c), abs(d))
    a, b, c, d = a / s, b / s, c / s, d / s
    n = np.sqrt(a * a + b * b + c * c + d * d)
    return a / n, b / n, c / n, d / n


@njit(cache=True, error_model="numpy", inline="always")
def _larger(largest, x):
    """``np.max``'s running step: a NaN, once met, is the result."""
    return largest if largest != largest else (x if (x > largest or x != x) else largest)


@njit(cache=True, error_model="numpy")
def _errors(q, w, q_ref, w_ref, out):
    """``out`` = final and largest attitude error, final and largest rate error (see :func:`errors_against`)."""
    att_max = om_max = att = om = 0.0
    for i in range(q.shape[0]):
        pw, px, py, pz = _unit(q[i, 0], q[i, 1], q[i, 2], q[i, 3])
        rw, rx, ry, rz = _unit(q_ref[i, 0], q_ref[i, 1], q_ref[i, 2], q_ref[i, 3])
        px, py, pz = px * -1.0, py * -1.0, pz * -1.0  # the conjugate, then rotations._qmul's product
        dw = pw * rw - px * rx - py * ry - pz * rz
        dx = pw * rx + px * rw + py * rz - pz * ry
        dy = pw * ry - px * rz + py * rw + pz * rx
        dz = pw * rz + px * ry - py * rx + pz * rw
        att = 2 * np.arctan2(np.sqrt(dx * dx + dy * dy + dz * dz), abs(dw))
        ex, ey, ez = w[i, 0] - w_ref[i, 0], w[i, 1] - w_ref[i, 1], w[i, 2] - w_ref[i, 2]
        om = np.sqrt(ex * ex + ey * ey + ez * ez)
        att_max = att if i == 0 else _larger(att_max, att)
        om_max = om if i == 0 else _larger(om_max, om)
    out[0], out[1], out[2], out[3] = att, att_max, om, om_max


def kinetic_energy(inertia, omega) -> np.ndarray:
    """``1/2 w.I w`` [J] for body rates ``(..., 3)``."""
    I = validate_inertia(inertia)
    omega = np.asarray(omega, dtype=float)
    return 0.5 * np.einsum("...i,ij,...j->...", omega, I, omega)


def world_momentum(inertia, q, omega) -> np.ndarray:
    """Angular momentum in world components ``R(q) I w`` [kg m^2/s], ``(..., 3)``."""
    I = validate_inertia(inertia)
    return rot.quat_rotate(q, np.asarray(omega, dtype=float) @ I.T)


def invariant_changes(inertia, traj: Trajectory, torque=None) -> dict:
    """The invariants' largest signed changes over a trajectory (:mod:`xcheck.invariants`): ``energy_change`` and
    ``momentum_change`` (relative; positive: gained, negative: damped) and ``momentum_turn`` [rad] (L's direction),
    each None where the motion does not keep it; ``norm_drift`` = max ||q| - 1| (of the quaternion the method
    integrates); for a symmetric top (Lagrange's case) ``spin_change``, its spin momentum about its axis relative to
    |L0| (signed); for DCM runs ``orthogonality_drift`` = max |R^T R - I|. Torque free, in one compiled pass with
    numpy's operations (bit for bit :func:`~xcheck.invariants.invariant_series`'s numbers)."""
    I = validate_inertia(inertia)
    q, w = _rows(traj.q, 4), _rows(traj.omega, 3)
    if not len(q) == len(w) > 0:
        raise ValueError(f"invariant_changes: expected as many (and some) quaternions as rates, got {len(q)} and "
                         f"{len(w)}")
    if torque is not None or not compiled_code_loaded():  # numpy's statement (see compiled_code_loaded)
        out = invariant_series(I, q, w, torque, traj.t).largest()
        norm = np.max(np.abs(np.linalg.norm(q, axis=-1) - 1.0))
    else:  # torque free: the series' operations in one compiled pass, their largest values kept
        E = kinetic_energy(I, w)
        found = np.empty(4)
        _changes(q, np.ascontiguousarray(w @ I.T), E, found)
        out = {"energy_change": float(found[0] / E[0]) if E[0] > 0 else 0.0, "momentum_change": float(found[1]),
               "momentum_turn": float(found[2])}
        norm = found[3]
    out["norm_drift"] = _norm_drift(traj, norm)
    form = torque.fixed_form() if torque is not None and hasattr(torque, "fixed_form") else None
    if form is not None:  # a symmetric top (Lagrange's): its spin momentum about its axis, relative to |L0|
        from .reference import lagrange_why_not

        if lagrange_why_not(I, *form) is None:
            e3 = form[0] / np.linalg.norm(form[0])
            spin = (w @ I) @ e3
            L0 = np.linalg.norm(world_momentum(I, q[:1], w[:1]))
            out["spin_change"] = largest_change((spin - spin[0]) / L0) if L0 > 0 else 0.0
    if "orthogonality" in traj.extras:
        out["orthogonality_drift"] = float(np.max(traj.extras["orthogonality"]))
    return out


def _norm_drift(traj: Trajectory, stored: float) -> float:
    """max ||q| - 1| of the quaternion the method integrates: an engine's own where the trajectory carries its norms
    (``extras["norm"]``: Drake integrates its quaternion unnormalised, xcheck reads it normalised), else the stored
    one's (``stored``)."""
    own = traj.extras.get("norm")
    return float(stored if own is None else np.max(np.abs(np.asarray(own, dtype=float) - 1.0)))


@njit(cache=True, error_model="numpy", inline="always")
def _largest(largest, x):
    """:func:`~xcheck.invariants.largest_change`'s running step: the first value largest in magnitude, a NaN once
    met."""
    return largest if largest != largest else (x if (abs(x) > abs(largest) or x != x) else largest)


@njit(cache=True, error_model="numpy")
def _changes(q, v, E, out):
    """``out`` = the largest (signed) E - E0, |H|/|H0| - 1 and angle (H, H0) with ``H = R(q) v``
    (``rotations.quat_rotate``'s operations), and max ||q| - 1| (see :func:`invariant_changes`)."""
    e_big = l_big = turn_big = n_max = 0.0
    h0x = h0y = h0z = h0 = 0.0
    for i in range(q.shape[0]):
        w, x, y, z = _unit(q[i, 0], q[i, 1], q[i, 2], q[i, 3])
        vx, vy, vz = v[i, 0], v[i, 1], v[i, 2]
        tx, ty, tz = 2 * (y * vz - z * vy), 2 * (z * vx - x * vz), 2 * (x * vy - y * vx)
        hx = vx + w * tx + (y * tz - z * ty)
        hy = vy + w * ty + (z * tx - x * tz)
        hz = vz + w * tz + (x * ty - y * tx)
        h = np.sqrt(hx * hx + hy * hy + hz * hz)
        if i == 0:
            h0x, h0y, h0z, h0 = hx, hy, hz, h
        if h0 > 0:
            size = h / h0 - 1.0
            cx, cy, cz = hy * h0z - hz * h0y, hz * h0x - hx * h0z, hx * h0y - hy * h0x
            turn = np.arctan2(np.sqrt(cx * cx + cy * cy + cz * cz), hx * h0x + hy * h0y + hz * h0z)
        else:
            size = turn = 0.0
        e = E[i] - E[0]
        norm = abs(np.sqrt(q[i, 0] * q[i, 0] + q[i, 1] * q[i, 1] + q[i, 2] * q[i, 2] + q[i, 3] * q[i, 3]) - 1.0)
        e_big = e if i == 0 else _largest(e_big, e)
        l_big = size if i == 0 else _largest(l_big, size)
        turn_big = turn if i == 0 else _larger(turn_big, turn)
        n_max = norm if i == 0 else _larger(n_max, norm)
    out[0], out[1], out[2], out[3] = e_big, l_big, turn_big, n_max


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
       that also covers its reference's accuracy); where the error rose between two steps below
       :data:`ROUNDOFF_SCALE` from within :data:`ROUNDOFF_BAND` of its lowest (the method reached its own
       round-off; a pre-asymptotic wiggle is far above its lowest), the steps after that rise are dropped, and so
       are errors within :data:`ROUNDOFF_BAND` of the smallest before it (an engine whose round-off floor is above the study's: EXUDYN's RK44 measured 3.03
       on its floor, 4.00 above it; its trapezoidal rule -1.24 on a floor whose noise dipped at the finest step);
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
    lowest = np.min(errors[finite])
    rises = [i for i in range(len(errors) - 1) if finite[i] and finite[i + 1] and errors[i + 1] > errors[i]
             and errors[i + 1] <= ROUNDOFF_SCALE and errors[i] <= ROUNDOFF_BAND * lowest]
    if rises:
        # the error rose at round-off scale: the method's own round-off from there on, which also bends the errors
        # just above it; only those ROUNDOFF_BAND times above its smallest before the rise are its truncation error
        ok[rises[0] + 1:] = False
        ok &= errors >= ROUNDOFF_BAND * np.min(errors[:rises[0] + 1][finite[:rises[0] + 1]])
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


def ladder_steps(dts, your_step: float | None) -> list:
    """The steps an order is fitted on (issue 59): all of ``dts``, but where the user's own step ``your_step`` [s]
    was added to a ladder of halvings it is off (a model's 0.01 s among 1/64 … 1/1024 s), that step and those at
    powers of two of it (the one beyond it that brackets it) are left out, so that the order is the ladder's, as it
    was without them: a pair of steps 1.28 apart turns the round-off's wiggles into wild local orders. (Where the
    ladder alone shows no order, a study fits every step: :func:`xcheck.study.assemble`.)"""
    dts = [float(d) for d in dts]
    if your_step is None or not any(same_step(d, your_step) for d in dts):
        return dts

    def key(d):  # steps at powers of two of each other share it
        k = float(np.log2(d))
        return round(k - np.floor(k), 6) % 1.0

    ladder = [d for d in dts if key(d) != key(your_step)]
    return ladder if len(ladder) >= 3 and len({key(d) for d in ladder}) == 1 else dts


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
