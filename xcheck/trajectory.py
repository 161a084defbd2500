"""The one result type every runner returns, ours or an engine's."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Trajectory", "continuous_quaternions", "step_plan", "equal_steps", "finite_rows", "until_non_finite", "same_step", "blow_up", "BLOW_UP_FACTOR", "fixed_step_start", "step_label", "time_grid", "check_step",
           "check_initial_state", "tolerances_at", "available_memory"]

#: Relative tolerance for treating ``duration / dt`` as an integer number of steps.
_INTEGER_STEPS_RTOL = 1e-9
#: The most steps a single run may take.
MAX_STEPS = 200_000_000
#: Peak memory of one run in a study, per step [bytes]: the states, the grid, the reference on the same grid
#: and the errors (measured: 410-510 B on the bundled scenarios, ours and MuJoCo's), with a margin.
BYTES_PER_STEP = 640


@dataclass
class Trajectory:
    """An attitude trajectory on a time grid.

    Attributes
    ----------
    t : ndarray (n+1,)
        Times [s]; ``t[0] = 0``, and ``t[-1] = duration`` when the run completed.
    q : ndarray (n+1, 4)
        Attitude quaternions [w, x, y, z] body -> world, sign-continuous along the run.
    omega : ndarray (n+1, 3)
        Body rates in body components [rad/s].
    status : str
        ``"ok"``, ``"singular"`` (a parametrization reached its singularity; the trajectory holds what
        was computed up to the last good step) or ``"failed"``.
    message : str
        Why the run stopped early (empty when ``"ok"``).
    method : str
    dt : float
        The nominal step [s].
    extras : dict
        Method-specific series, e.g. ``"euler"`` (n+1, 3) for Euler-angle runs, ``"orthogonality"``
        (n+1,) ``max |R^T R - I|`` for DCM runs.
    """

    t: np.ndarray
    q: np.ndarray
    omega: np.ndarray
    status: str = "ok"
    message: str = ""
    method: str = ""
    dt: float = float("nan")
    extras: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def __len__(self) -> int:
        return len(self.t)


def continuous_quaternions(q: np.ndarray) -> np.ndarray:
    """Flip signs along axis 0 so that consecutive quaternions have a non-negative dot product
    (``q`` and ``-q`` are the same attitude; plots and differences want continuity)."""
    q = np.array(q, dtype=float, copy=True)
    if len(q) < 2:
        return q
    d = np.sum(q[1:] * q[:-1], axis=-1)
    flips = np.cumprod(np.where(d < 0, -1.0, 1.0))
    q[1:] *= flips[:, None]
    return q


def step_plan(dt, duration) -> tuple[int, float]:
    """Number of steps and the length of the last one, so that a run ends exactly at ``duration``.

    When ``duration / dt`` is an integer (to 1e-9 relative) there are that many equal steps; otherwise
    ``ceil(duration / dt)`` steps of ``dt`` of which the last is shortened to land on ``duration``.
    """
    try:
        dt = float(dt)
        duration = float(duration)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"dt and duration: expected numbers of seconds, got {dt!r} and {duration!r}") from exc
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt: expected a positive finite step in seconds, got {dt!r}")
    if not (np.isfinite(duration) and duration > 0):
        raise ValueError(f"duration: expected a positive finite time in seconds, got {duration!r}")
    ratio = duration / dt
    nearest = round(ratio)
    n = int(nearest) if nearest >= 1 and abs(ratio - nearest) <= _INTEGER_STEPS_RTOL * ratio else int(np.ceil(ratio))
    if n > MAX_STEPS:
        raise ValueError(f"dt: {n} steps of {dt:g} s over {duration:g} s exceeds the limit of {MAX_STEPS}")
    return n, duration - (n - 1) * dt


def fixed_step_start(integrators, integrator: str, q0, omega0, dt, duration, why: str):
    """The checked start of a run by an engine's integrator taking equal steps (Drake's, EXUDYN's): ``integrator``
    among the names of ``integrators``, the initial state (:func:`check_initial_state`) and the number of steps
    (:func:`equal_steps`, ``why`` said when ``dt`` does not divide ``duration``). ``(q0, omega0, n)``."""
    if integrator not in integrators:
        raise ValueError(f"integrator: unknown {integrator!r}; expected one of {', '.join(integrators)}")
    q0, omega0 = check_initial_state(q0, omega0)
    return q0, omega0, equal_steps(dt, duration, why)


def finite_rows(*arrays) -> int:
    """How many leading rows (first axis) are finite in every one of ``arrays``: an engine's run up to the state it blew
    up at (the conversions at its boundary refuse a non-finite one)."""
    with np.errstate(over="ignore", invalid="ignore"):
        good = np.logical_and.reduce([np.all(np.isfinite(np.asarray(a, dtype=float).reshape(len(a), -1)), axis=1)
                                      for a in arrays])
    return int(np.argmin(good)) if not good.all() else len(good)


def quaternion_rows(q, *arrays) -> int:
    """:func:`finite_rows` of ``q`` and ``arrays``, and no further than the first quaternion of ``q`` whose norm has
    collapsed to zero or overflowed (an engine's additive quaternion, grown by explicit Euler over an hour: normalised,
    it is zero, no rotation)."""
    k = finite_rows(q, *arrays)
    with np.errstate(over="ignore", invalid="ignore"):
        n = np.linalg.norm(np.asarray(q[:k], dtype=float), axis=1)
        gone = np.flatnonzero(~(np.isfinite(n) & (n > 1e-150)))
    return int(gone[0]) if gone.size else k


def until_non_finite(t, q, omega, *, method: str, dt: float, extras=None) -> "Trajectory":
    """An engine's run as a :class:`Trajectory` from its times ``t`` and the ``q``, ``omega`` rows up to its first
    non-finite state (:func:`finite_rows`; as many as ``t``'s when there is none): fewer fail the run, saying when."""
    k = len(q)
    traj = Trajectory(t=np.asarray(t)[:k], q=continuous_quaternions(q) if k else np.empty((0, 4)),
                      omega=np.asarray(omega).reshape(-1, 3), method=method, dt=float(dt), extras=extras or {})
    if k < len(t):
        traj.status, traj.message = "failed", f"{method}: blew up: the state became non-finite at t = {t[k]:.6g} s"
    return traj


def same_step(a: float, b: float) -> bool:
    """Whether two steps [s] are the same step (to 1e-9 relative: a step written in a file, derived, or run)."""
    return abs(float(a) - float(b)) <= 1e-9 * float(b)


#: A torque-free run whose body rate grows past this many times the largest its body can reach has blown up.
BLOW_UP_FACTOR = 10.0


def blow_up(t, omega, inertia, omega0, *, method: str) -> str | None:
    """Why a torque-free free body's run has **blown up** (issue 60: a blow-up is called one first, before any
    engine's own explanation), or None. Its |L| is conserved, so its rate never exceeds ``|J w0| / J_min``
    (|w| <= |J w| / J_min); a rate past :data:`BLOW_UP_FACTOR` times that bound is growth no truncation error of a
    stable run explains. ``omega`` (n, 3) [rad/s] in either frame (only its norm is read); ``inertia`` (3, 3)."""
    J = np.asarray(inertia, dtype=float)
    bound = float(np.linalg.norm(J @ np.asarray(omega0, dtype=float)) / np.linalg.eigvalsh(J)[0])
    rates = np.linalg.norm(np.asarray(omega, dtype=float).reshape(-1, 3), axis=1)
    over = np.flatnonzero(~(rates <= BLOW_UP_FACTOR * bound)) if bound > 0 else np.empty(0, int)
    if not len(over):
        return None
    k = int(over[0])
    return (f"{method}: blew up: its body rate grew to {rates[k]:.3g} rad/s by t = {float(t[k]):.6g} s, more than "
            f"{BLOW_UP_FACTOR:g} times the largest a torque-free body of this inertia can reach (|J w0| / J_min = "
            f"{bound:.3g} rad/s)")


def equal_steps(dt, duration, why: str) -> int:
    """The number of equal steps ``dt`` that make ``duration``, for an engine that cannot shorten its last step
    (``why``, said when ``dt`` does not divide ``duration``: "Drake's log is periodic")."""
    n, last_h = step_plan(dt, duration)
    if abs(last_h - float(dt)) > 1e-9 * float(dt):
        raise ValueError(f"dt: {float(dt):g} s does not divide the duration {float(duration):g} s ({why})")
    return n


def check_initial_state(q0, omega0, *, batch: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The initial attitude, normalised, and body rate of a run, or a ValueError naming the argument.

    ``q0``: [w, x, y, z] body -> world, shape (4,) (``batch``: (N, 4)), finite and not zero (normalised here,
    without overflow); ``omega0``: body rate [rad/s], shape (3,) (``batch``: (N, 3)), finite. The one place
    an initial state is checked: our integrators, the engines and the references call it, and the scenario
    reader reports its message under the key it read.
    """
    from .body import MAX_RATE
    from .rotations import _unit_quat

    def numbers(x, name, n, unit):
        try:
            a = np.asarray(x, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{name}: expected {n} numbers{unit}, got {x!r}") from None
        want = 2 if batch else 1
        if a.ndim != want or a.shape[-1] != n:
            shape = f"(N, {n})" if batch else f"({n},)"
            raise ValueError(f"{name}: expected shape {shape}{unit}, got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: contains non-finite values")
        return a

    q = _unit_quat(numbers(q0, "q0", 4, " [w, x, y, z]"), "q0")
    w = numbers(omega0, "omega0", 3, " [rad/s]")
    big = float(np.max(np.abs(w))) if w.size else 0.0
    fastest = big * float(np.max(np.linalg.norm(w / big, axis=-1))) if big > 0 else 0.0  # (1e300 squared overflows)
    if not fastest <= MAX_RATE:
        raise ValueError(f"omega0: |omega| = {fastest:.3g} rad/s, beyond the {MAX_RATE:.0e} rad/s xcheck takes (a million "
                         "rpm: faster than any spinning machine)")
    if batch and q.shape[0] != w.shape[0]:
        raise ValueError(f"q0, omega0: expected as many attitudes as body rates, got {q.shape[0]} and {w.shape[0]}")
    return q, w


def time_grid(n: int, dt: float, duration: float) -> np.ndarray:
    """``[0, dt, 2 dt, ..., (n-1) dt, duration]`` (n + 1 points), each time computed, not accumulated."""
    t = np.arange(n + 1, dtype=float) * dt
    t[-1] = duration
    return t


def available_memory() -> int | None:
    """Memory available to new work [bytes] (Linux ``MemAvailable``, else the physical memory), or None."""
    import os

    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


def check_step(dt, duration, *, runs_at_once: int | None = None) -> int:
    """The number of steps of a run at ``dt`` over ``duration``, or a ValueError saying why it cannot run:
    a step that is not a positive finite number, larger than the duration, or a run whose memory
    (:data:`BYTES_PER_STEP` a step, ``runs_at_once`` runs in parallel: default the CPU count) would exceed
    half the memory available. Checked before anything is allocated."""
    import os

    dt, duration = float(dt), float(duration)
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"expected a positive finite step in seconds, got {dt!r}")
    if dt > duration * (1 + _INTEGER_STEPS_RTOL):
        raise ValueError(f"the step {dt:g} s is longer than the duration {duration:g} s")
    ratio = duration / dt
    if not ratio <= MAX_STEPS:  # also inf
        raise ValueError(f"the step {dt:g} s over {duration:g} s is {ratio:.3g} steps, more than the limit of "
                         f"{MAX_STEPS:.3g} steps a run")
    n = int(np.ceil(ratio * (1 - _INTEGER_STEPS_RTOL)))
    runs = runs_at_once or os.cpu_count() or 1
    need = (n + 1) * BYTES_PER_STEP * runs
    avail = available_memory()
    if avail is not None and need > avail / 2:
        raise ValueError(f"the step {dt:g} s over {duration:g} s is {n:.3g} steps; {runs} such run(s) at once need about "
                         f"{need / 2**30:.3g} GiB, more than half of the {avail / 2**30:.3g} GiB available here: use a "
                         "larger step or a shorter duration")
    return step_plan(dt, duration)[0]


def tolerances_at(rtol, defaults: tuple[float, float]) -> tuple[float, float]:
    """An adaptive method's ``(relative, absolute)`` tolerances at the relative tolerance ``rtol``, the absolute
    one in the proportion of the method's ``defaults`` (returned as they are for None); a ValueError for an
    ``rtol`` outside (0, 1)."""
    rel, abs_ = defaults
    if rtol is None:
        return rel, abs_
    if not (np.isfinite(rtol) and 0 < rtol < 1):
        raise ValueError(f"rtol: expected a relative tolerance in (0, 1), got {rtol!r}")
    return float(rtol), float(rtol) * abs_ / rel


def step_label(dt: float) -> str:
    """A step as people read it: ``1/1024`` for a power of two below one second, else ``0.3``."""
    k = math.log2(1 / dt)
    return f"1/{int(round(1 / dt))}" if dt < 1 and abs(k - round(k)) < 1e-9 else f"{dt:g}"
