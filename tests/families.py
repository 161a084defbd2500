"""Random bodies and states from the delicate families of the exact references (issue 36): what users bring,
not what we tuned. Each generator takes a ``numpy.random.Generator`` and returns a case: a dict with
``inertia`` (3, 3) [kg m^2] in body components (principal axes turned at random), ``q0`` [w, x, y, z], ``omega0``
[rad/s], ``duration`` [s], ``torque`` (None, a :class:`~xcheck.fields.GravityTorque`, or a gyrostat's
:class:`~xcheck.fields.WheelsTorque`) and ``family``."""

from __future__ import annotations

import numpy as np

from xcheck import rotations as rot


def random_rotation(rng) -> np.ndarray:
    q = rng.normal(size=4)
    return rot.quat_to_dcm(q / np.linalg.norm(q))


def _turned(moments, rng) -> np.ndarray:
    V = random_rotation(rng)
    return V @ np.diag(moments) @ V.T, V


def _unit(rng) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _loguniform(rng, lo, hi) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _case(family, inertia, q0, omega0, duration, torque=None, **extra) -> dict:
    return {"family": family, "inertia": inertia, "q0": np.asarray(q0, float), "omega0": np.asarray(omega0, float),
            "duration": float(duration), "torque": torque, **extra}


def _free_body(rng, family, moments, omega_principal, rate=None):
    """A torque-free case: ``moments`` and the rate in principal components, turned at random; the duration
    covers 1 to 20 of the body's own turns (its rate's), at most 300 rad in all."""
    I, V = _turned(moments, rng)
    omega0 = V @ np.asarray(omega_principal, dtype=float)
    if rate is not None:
        omega0 *= rate / np.linalg.norm(omega0)
    speed = np.linalg.norm(omega0)
    duration = min(rng.uniform(1, 20) * 2 * np.pi / speed, 300.0 / speed) if speed > 0 else 1.0
    q0 = rot.dcm_to_quat(random_rotation(rng))
    return _case(family, I, q0, omega0, duration)


def _triangle_moments(rng, j1, j2):
    """``(j1, j2, j3)`` with ``j3`` drawn within the triangle inequality (j2 <= j3 <= j1 + j2), sorted."""
    return np.sort([j1, j2, rng.uniform(max(j1, j2), j1 + j2)])


def generic(rng):
    m = _triangle_moments(rng, rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.0))
    return _free_body(rng, "generic", m, _unit(rng), rate=_loguniform(rng, 0.1, 10))


def thin(rng):
    """Thin bodies: the smallest moment 1e-3 ... 0.1 of the middle one (a plate, a rod-like panel)."""
    j2 = rng.uniform(0.5, 2.0)
    j1 = j2 * _loguniform(rng, 1e-3, 0.1)
    return _free_body(rng, "thin", _triangle_moments(rng, j1, j2), _unit(rng), rate=_loguniform(rng, 0.1, 20))


def near_axisymmetric(rng):
    """Two moments 1e-15 ... 1e-3 apart (relative): down to the round-off of a turned tensor's moments."""
    a, c = rng.uniform(0.5, 1.0), rng.uniform(0.5, 1.0)
    if a == c:
        c *= 1.5
    eps = _loguniform(rng, 1e-15, 1e-3)
    m = np.sort([a, a * (1 + eps), min(c, 2 * a * 0.999)])
    return _free_body(rng, "near-axisymmetric", m, _unit(rng), rate=_loguniform(rng, 0.1, 20))


def near_isotropic(rng):
    """All three moments within 1e-6 ... 1e-2 of each other."""
    base = rng.uniform(0.5, 2.0)
    spread = _loguniform(rng, 1e-6, 1e-2)
    m = np.sort(base * (1 + spread * rng.uniform(-1, 1, size=3)))
    return _free_body(rng, "near-isotropic", m, _unit(rng), rate=_loguniform(rng, 0.1, 20))


def near_separatrix(rng):
    """Started near the intermediate axis's separatrix: ``|h^2 - 2 E I2| / h^2`` from 1e-10 to 1e-3, either side."""
    m = _triangle_moments(rng, rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.0))
    j1, j2, j3 = m
    # on the separatrix: j1 (j2 - j1) w1^2 = j3 (j3 - j2) w3^2; then the energy nudged
    w1 = rng.uniform(0.1, 1.0)
    w3 = w1 * np.sqrt(j1 * (j2 - j1) / (j3 * (j3 - j2)))
    w2 = rng.uniform(0.2, 2.0) * rng.choice([-1, 1])
    w = np.array([w1, w2, w3 * rng.choice([-1, 1])])
    h2 = np.sum((m * w) ** 2)
    target = _loguniform(rng, 1e-10, 1e-3) * rng.choice([-1, 1])  # (h^2 - 2 E j2) / h^2
    # change w3 by d: h^2 - 2 E j2 gains j3 (j3 - j2) ((w3 + d)^2 - w3^2)
    w3n = np.sqrt(max(w[2] ** 2 + target * h2 / (j3 * (j3 - j2)), 0.0)) * np.sign(w[2])
    w[2] = w3n
    return _free_body(rng, "near-separatrix", m, w, rate=_loguniform(rng, 0.5, 5))


def fast(rng):
    m = _triangle_moments(rng, rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.0))
    return _free_body(rng, "fast", m, _unit(rng), rate=100.0)


def slow(rng):
    m = _triangle_moments(rng, rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.0))
    case = _free_body(rng, "slow", m, _unit(rng), rate=0.01)
    case["duration"] = rng.uniform(10, 1000)
    return case


def axisymmetric(rng):
    a, c = rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.9)
    c = min(c, 2 * a)
    return _free_body(rng, "axisymmetric", np.array([a, a, c]), _unit(rng), rate=_loguniform(rng, 0.1, 30))


TORQUE_FREE = (generic, thin, near_axisymmetric, near_isotropic, near_separatrix, fast, slow, axisymmetric)


# ---------------------------------------------------------------------------------------------------------
# heavy symmetric tops (Lagrange's case), on a random pivot: the inertia about the pivot A (E - e e^T) + C e e^T
# about the direction e of the centre of mass c, both in a random body frame; gravity in a random direction
# ---------------------------------------------------------------------------------------------------------
def _top(rng, family, theta, psi_dot, spin, theta_dot=0.0, phi=None):
    """A top: its axis at ``theta`` from the upward vertical, precessing at ``psi_dot``, nodding at ``theta_dot``,
    with ``spin`` = w3 (the body rate about its axis) [rad/s]."""
    from xcheck.fields import GravityTorque

    A = rng.uniform(0.005, 0.05)
    C = A * rng.uniform(0.2, 1.95)
    mass, length, g = rng.uniform(0.2, 2.0), rng.uniform(0.02, 0.2), 9.81
    e = _unit(rng)
    F = rot.frame_with_z(e)  # the top's frame in body components: its third axis along c
    turn = rot.quat_to_dcm(rot.rotvec_to_quat(np.array([0.0, 0.0, rng.uniform(0, 2 * np.pi)])))
    F = F @ turn
    I = F @ np.diag([A, A, C]) @ F.T
    centre = length * e
    up = _unit(rng)
    G = rot.frame_with_z(up)  # the vertical frame in world components
    phi = rng.uniform(0, 2 * np.pi) if phi is None else phi
    psi = rng.uniform(0, 2 * np.pi)
    angles = np.array([psi, theta, phi])
    qT = rot.euler_to_quat(angles, "313")  # top frame -> vertical frame
    wT = rot.euler_rates_to_omega(angles, np.array([psi_dot, theta_dot, spin - psi_dot * np.cos(theta)]), "313")
    q0 = rot.quat_mul(rot.quat_mul(rot.dcm_to_quat(G), qT), rot.quat_conj(rot.dcm_to_quat(F)))
    omega0 = F @ wT
    torque = GravityTorque(centre, mass, -g * up)
    nod = 2 * np.pi * A / max(abs(C * spin), 1e-9)  # the fast top's nutation period, roughly
    duration = float(np.clip(rng.uniform(2, 10) * max(nod, 0.05), 0.2, 5.0))
    return _case(family, I, q0, omega0, duration, torque, A=A, C=C, mgl=mass * g * length)


def top_steady(rng):
    """Steady precession, the axis 5 ... 175 deg from the vertical: ``c1 = 0`` of the cubic, a double root."""
    theta = np.radians(rng.uniform(5, 175))
    case = _top(rng, "top-steady", theta, 1.0, 1.0)
    A, C, mgl = case["A"], case["C"], case["mgl"]  # the spin that makes the precession steady: b = (beta + 2 u psi'^2) / (2 psi')
    psi_dot = _loguniform(rng, 0.3, 10) * rng.choice([-1, 1])
    u = np.cos(theta)
    beta = 2 * mgl / A
    b = (beta + 2 * u * psi_dot ** 2) / (2 * psi_dot)
    spin = b * A / C
    return _retop(rng, case, theta, psi_dot, spin)


def _retop(rng, case, theta, psi_dot, spin, theta_dot=0.0):
    """``case``'s top (its body, pivot and gravity) at another state."""
    from xcheck.fields import GravityTorque

    torque = case["torque"]
    centre = torque.centre
    e = centre / np.linalg.norm(centre)
    F = rot.frame_with_z(e)
    up = -torque.gravity / np.linalg.norm(torque.gravity)
    G = rot.frame_with_z(up)
    angles = np.array([rng.uniform(0, 2 * np.pi), theta, rng.uniform(0, 2 * np.pi)])
    qT = rot.euler_to_quat(angles, "313")
    wT = rot.euler_rates_to_omega(angles, np.array([psi_dot, theta_dot, spin - psi_dot * np.cos(theta)]), "313")
    q0 = rot.quat_mul(rot.quat_mul(rot.dcm_to_quat(G), qT), rot.quat_conj(rot.dcm_to_quat(F)))
    out = dict(case)
    out.update(q0=q0, omega0=F @ wT, torque=GravityTorque(centre, torque.mass, torque.gravity))
    nod = 2 * np.pi * case["A"] / max(abs(case["C"] * spin), 1e-9)
    out["duration"] = float(np.clip(rng.uniform(2, 10) * max(nod, 0.05), 0.2, 5.0))
    return out


def top_near_steady(rng):
    """Steady precession nudged by 1e-9 ... 1e-3 of its rate: a near-double root."""
    case = top_steady(rng)
    nudge = 1 + _loguniform(rng, 1e-9, 1e-3) * rng.choice([-1, 1])
    case = dict(case, omega0=case["omega0"] * nudge, family="top-near-steady")
    return case


def top_sleeping(rng):
    """Near sleeping: a fast top whose axis starts 1.5 ... 5 deg from the vertical (its axis keeps > 0.57 deg
    from it: the closed form's limit)."""
    case = _top(rng, "top-near-sleeping", 0.1, 0.0, 1.0)
    spin = rng.uniform(30, 200)
    return dict(_retop(rng, case, np.radians(rng.uniform(1.5, 5)), rng.uniform(-0.5, 0.5), spin),
                family="top-near-sleeping")


def top_looping(rng):
    """Started precessing backwards: the axis loops (psi' changes sign within each nod)."""
    case = _top(rng, "top-looping", 0.5, 0.0, 1.0)
    theta = np.radians(rng.uniform(10, 80))
    spin = rng.uniform(20, 120)
    return dict(_retop(rng, case, theta, -rng.uniform(0.5, 3), spin), family="top-looping")


def top_hanging(rng):
    """Hanging below its pivot, 100 ... 178 deg from the upward vertical, spinning and nodding."""
    case = _top(rng, "top-hanging", 2.0, 0.0, 1.0)
    theta = np.radians(rng.uniform(100, 178))
    return dict(_retop(rng, case, theta, rng.uniform(-3, 3), rng.uniform(-50, 50), rng.uniform(-2, 2)),
                family="top-hanging")


def top_generic(rng):
    case = _top(rng, "top-generic", 0.5, 0.0, 1.0)
    theta = np.radians(rng.uniform(10, 170))
    return dict(_retop(rng, case, theta, rng.uniform(-5, 5), rng.uniform(-80, 80), rng.uniform(-3, 3)),
                family="top-generic")


TOPS = (top_steady, top_near_steady, top_sleeping, top_looping, top_hanging, top_generic)


def gyrostat(rng):
    """An axisymmetric gyrostat: a constant internal momentum along the symmetry axis (a free wheel on it)."""
    from xcheck.fields import WheelsTorque

    a, c = rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.9)
    c = min(c, 2 * a)
    I, V = _turned([a, a, c], rng)
    axis = V[:, 2]
    h = axis * rng.uniform(-5, 5)
    omega0 = _unit(rng) * _loguniform(rng, 0.1, 10)
    speed = max(np.linalg.norm(omega0), np.linalg.norm(h) / a)
    q0 = rot.dcm_to_quat(random_rotation(rng))
    torque = WheelsTorque(h, [], wheels=[])
    return _case("gyrostat", I, q0, omega0, min(rng.uniform(1, 20) * 2 * np.pi / speed, 300 / speed), torque)
