"""The compiled torque kernel: every torque model evaluated from plain arrays, without a Python call per stage.

A torque model is an integer *kind* (:data:`FREE`, :data:`CONSTANT`, :data:`MAGNETIC`, :data:`GRAVITY_GRADIENT`,
:data:`WHEELS`, :data:`SUM` of those), a parameter vector ``P``
and a table ``T`` (2-D, empty when unused). ``P`` is read by named slot:

==============  ==========================================================================================
slot            meaning
==============  ==========================================================================================
``VECTOR``      ``P[0:3]``: the constant torque [N m] (CONSTANT) or the permanent dipole M_p [A m^2] (MAGNETIC)
``EVALUATOR``   ``P[3]``: how the field is evaluated (:data:`TABLE`, :data:`CONSTANT_FIELD`, :data:`ORBIT_DIPOLE`,
                :data:`ORBIT_FLOW`)
``FRAME``       ``P[4]``: the components the field is given in, :data:`BODY` or :data:`WORLD` (then the torque
                depends on attitude: ``H_body = R^T H_world``)
``FIELD``       ``P[5:]``: the field's own parameters, in the order of its declared ``slots``
==============  ==========================================================================================

Magnetic torque (seed 004 eq. 174): ``t' = mu0 (M_p x H)`` in body components, ``H`` the field strength [A/m]
in body components, ``mu0 = 4 pi 1e-7`` H/m; ``B = mu0 H`` [T].

Every ``cache=True`` function of the fields lives in this file (see :data:`xcheck._jit.COMPILED_SOURCES`): the
integrator kernels compile it into themselves.
"""

from __future__ import annotations

import numpy as np

from .._jit import njit

#: Vacuum permeability [H/m] as used by seed 004 eq. 174.
MU0 = 4e-7 * np.pi

# torque kinds
FREE = 0
CONSTANT = 1
MAGNETIC = 2
SUM = 3  # torques that compose: P = [n, attitude-dependent (0/1), (kind, start, length) per term, then each term's
#          own P]; T the one table
GRAVITY_GRADIENT = 4  # P = [I (9, row by row, body frame), orbit radius, mean motion, inclination, RAAN, u0]
WHEELS = 5  # a gyrostat's wheels: P = [h0 (3), n, then per motor command: axis (3), peak torque, t0, t1]

# slots of P
VECTOR = 0
EVALUATOR = 3
FRAME = 4
FIELD = 5

# field evaluators (P[EVALUATOR])
TABLE = 0  # T's columns 1-3 linearly interpolated in time (column 0)
CONSTANT_FIELD = 1  # the field's slots (Hx, Hy, Hz)
ORBIT_DIPOLE = 2  # a tilted dipole Earth along a circular orbit (slots: OrbitDipoleField.slots)
ORBIT_FLOW = 3  # a vector along a circular orbit's velocity (slots: scale, mean motion, inclination, RAAN, u0)

# field frames (P[FRAME])
BODY = 0
WORLD = 1


@njit(cache=True, error_model="numpy", inline="always")
def interp_rows(T, t):
    """Linear interpolation of the table columns 1-3 at time ``t`` (column 0 ascending), as a tuple."""
    n = T.shape[0]
    i = np.searchsorted(T[:, 0], t, side="right") - 1
    if i < 0:
        i = 0
    if i > n - 2:
        i = n - 2
    s = (t - T[i, 0]) / (T[i + 1, 0] - T[i, 0])
    return (T[i, 1] + s * (T[i + 1, 1] - T[i, 1]),
            T[i, 2] + s * (T[i + 1, 2] - T[i, 2]),
            T[i, 3] + s * (T[i + 1, 3] - T[i, 3]))


@njit(cache=True, error_model="numpy", inline="always")
def world_to_body(q, vx, vy, vz):
    """``R(q)^T v`` for a (not necessarily unit) quaternion ``q`` [w, x, y, z], normalised here."""
    n = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    w = q[0] / n
    x = -q[1] / n  # rotation by the conjugate: u = -vec(q)
    y = -q[2] / n
    z = -q[3] / n
    # v + 2 w (u x v) + 2 u x (u x v)
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty),
            vy + w * ty + (z * tx - x * tz),
            vz + w * tz + (x * ty - y * tx))


@njit(cache=True, error_model="numpy", inline="always")
def orbit_direction(n, inc, raan, u0, t):
    """The unit position vector (world components) of a circular orbit at time ``t``: argument of latitude
    ``u0 + n t``, inclination ``inc``, node ``raan`` [rad]."""
    u = u0 + n * t
    cu, su, ci, si, cO, sO = np.cos(u), np.sin(u), np.cos(inc), np.sin(inc), np.cos(raan), np.sin(raan)
    return cO * cu - sO * su * ci, sO * cu + cO * su * ci, su * si


@njit(cache=True, error_model="numpy", inline="always")
def orbit_velocity_direction(n, inc, raan, u0, t):
    """The unit velocity vector (world components) of the circular orbit of :func:`orbit_direction`: its
    derivative with respect to the argument of latitude."""
    u = u0 + n * t
    cu, su, ci, si, cO, sO = np.cos(u), np.sin(u), np.cos(inc), np.sin(inc), np.cos(raan), np.sin(raan)
    return -cO * su - sO * cu * ci, -sO * su + cO * cu * ci, cu * si


@njit(cache=True, error_model="numpy", _nrt=False)
def gravity_gradient_torque(P, t, q, out):
    """Gravity-gradient torque [N m] in body components (issue 28): ``3 n^2 (o x I o)`` with ``n^2 = mu / r^3`` and
    ``o`` the nadir (the orbit's position direction, sign immaterial) in body components, along the circular orbit
    of the orbit field models."""
    rx, ry, rz = orbit_direction(P[10], P[11], P[12], P[13], t)
    ox, oy, oz = world_to_body(q, rx, ry, rz)
    ix = P[0] * ox + P[1] * oy + P[2] * oz
    iy = P[3] * ox + P[4] * oy + P[5] * oz
    iz = P[6] * ox + P[7] * oy + P[8] * oz
    k = 3.0 * P[10] * P[10]
    out[0] = k * (oy * iz - oz * iy)
    out[1] = k * (oz * ix - ox * iz)
    out[2] = k * (ox * iy - oy * ix)


@njit(cache=True, error_model="numpy", inline="always")
def pulse(u, t0, t1, t):
    """A motor's torque pulse ``u sin^2(pi s)``, ``s = (t - t0) / (t1 - t0)`` on ``[t0, t1]`` and zero outside:
    ``(its integral from t0 to t, its value)``. The value and its slope are continuous (zero at both ends), so a
    step that ends at ``t0`` or ``t1`` sees a smooth torque on either side and keeps its order."""
    if t <= t0:
        return 0.0, 0.0
    d = t1 - t0
    if t >= t1:
        return 0.5 * u * d, 0.0
    s = (t - t0) / d
    sn = np.sin(np.pi * s)
    return u * d * (0.5 * s - np.sin(2.0 * np.pi * s) / (4.0 * np.pi)), u * sn * sn


@njit(cache=True, error_model="numpy", _nrt=False)
def wheels_torque(P, t, w, out):
    """What a gyrostat's wheels do to the body (issue 28): ``-w x h(t) - h'(t)`` [N m], body components, so that
    ``I w' + w x (I w + h) = tau - h'`` (the gyrostat form of Euler's equation) is the rigid body's with this torque
    added. ``h`` is the wheels' absolute axial momentum along their axes, ``h0`` plus each motor command's pulse
    integral (:func:`pulse`), ``I`` the body's inertia less each wheel's axial moment about its axis (see
    :class:`xcheck.fields.WheelsTorque`): ``h`` is then a function of time alone."""
    hx, hy, hz = P[0], P[1], P[2]
    dx = dy = dz = 0.0
    for k in range(int(P[3])):
        b = 4 + 6 * k
        integral, value = pulse(P[b + 3], P[b + 4], P[b + 5], t)
        hx += integral * P[b]
        hy += integral * P[b + 1]
        hz += integral * P[b + 2]
        dx += value * P[b]
        dy += value * P[b + 1]
        dz += value * P[b + 2]
    out[0] = -(w[1] * hz - w[2] * hy) - dx
    out[1] = -(w[2] * hx - w[0] * hz) - dy
    out[2] = -(w[0] * hy - w[1] * hx) - dz


@njit(cache=True, error_model="numpy", inline="always")
def orbit_dipole_world(p, t):
    """Field strength H [A/m] in world (inertial) components of a dipole Earth along a circular orbit.

    ``p`` (the slots of :class:`~xcheck.fields.OrbitDipoleField`): orbit radius [m], mean motion [rad/s],
    inclination, right ascension of the ascending node, argument of latitude at t = 0, Earth rotation angle
    at t = 0 [rad], Earth rotation rate [rad/s], dipole moment in Earth-fixed components [A m^2].
    ``H = (3 (m.r^) r^ - m) / (4 pi |r|^3)``.
    """
    a, n, inc, raan, u0, g0, we = p[0], p[1], p[2], p[3], p[4], p[5], p[6]
    rx, ry, rz = orbit_direction(n, inc, raan, u0, t)
    g = g0 + we * t  # Earth-fixed -> inertial: rotation by g about z
    cg, sg = np.cos(g), np.sin(g)
    mx = cg * p[7] - sg * p[8]
    my = sg * p[7] + cg * p[8]
    mz = p[9]
    mr = mx * rx + my * ry + mz * rz
    k = 1.0 / (4.0 * np.pi * a * a * a)
    return k * (3.0 * mr * rx - mx), k * (3.0 * mr * ry - my), k * (3.0 * mr * rz - mz)


@njit(cache=True, error_model="numpy", inline="always")
def field_body(P, T, t, q):
    """Field strength H [A/m] in body components of the field described by ``P[EVALUATOR:]`` and ``T``."""
    evaluator = int(P[EVALUATOR])
    p = P[FIELD:]
    if evaluator == TABLE:
        hx, hy, hz = interp_rows(T, t)
    elif evaluator == CONSTANT_FIELD:
        hx, hy, hz = p[0], p[1], p[2]
    elif evaluator == ORBIT_FLOW:
        hx, hy, hz = orbit_velocity_direction(p[1], p[2], p[3], p[4], t)
        hx, hy, hz = p[0] * hx, p[0] * hy, p[0] * hz
    else:  # ORBIT_DIPOLE
        hx, hy, hz = orbit_dipole_world(p, t)
    if P[FRAME] == WORLD:
        return world_to_body(q, hx, hy, hz)
    return hx, hy, hz


@njit(cache=True, error_model="numpy", _nrt=False)
def magnetic_torque(P, T, t, q, out):
    """Seed 004 eq. 174, ``t' = mu0 (M_p x H)``: the MAGNETIC model's torque [N m] in body components (a call
    of its own: the field evaluators are long, and inlining them into every stage derivative costs seconds of
    compile for a few nanoseconds)."""
    hx, hy, hz = field_body(P, T, t, q)
    mx, my, mz = P[VECTOR], P[VECTOR + 1], P[VECTOR + 2]
    out[0] = MU0 * (my * hz - mz * hy)
    out[1] = MU0 * (mz * hx - mx * hz)
    out[2] = MU0 * (mx * hy - my * hx)


@njit(cache=True, error_model="numpy", _nrt=False)
def sum_torque(P, T, t, q, w, out):
    """The SUM model's torque [N m]: its terms (each with its own slice of ``P``) evaluated one after the other and
    added, in the order given (a call of its own, as :func:`magnetic_torque`)."""
    sx = sy = sz = 0.0
    for i in range(int(P[0])):
        kind, start, length = int(P[2 + 3 * i]), int(P[3 + 3 * i]), int(P[4 + 3 * i])
        if kind == CONSTANT:
            out[0], out[1], out[2] = P[start], P[start + 1], P[start + 2]
        elif kind == MAGNETIC:
            magnetic_torque(P[start:start + length], T, t, q, out)
        elif kind == GRAVITY_GRADIENT:
            gravity_gradient_torque(P[start:start + length], t, q, out)
        elif kind == WHEELS:
            wheels_torque(P[start:start + length], t, w, out)
        else:
            out[0] = out[1] = out[2] = 0.0
        sx += out[0]
        sy += out[1]
        sz += out[2]
    out[0], out[1], out[2] = sx, sy, sz


@njit(cache=True, error_model="numpy", _nrt=False)
def field_torque(kind, P, T, t, q, w, out):
    """The torque of a MAGNETIC, GRAVITY_GRADIENT, WHEELS or SUM model (see :func:`torque_eval`): called, not inlined
    (each kind inlined into every stage derivative of every scheme cost a fresh clone 10 s more of compiling)."""
    if kind == MAGNETIC:
        magnetic_torque(P, T, t, q, out)
    elif kind == GRAVITY_GRADIENT:
        gravity_gradient_torque(P, t, q, out)
    elif kind == WHEELS:
        wheels_torque(P, t, w, out)
    else:
        sum_torque(P, T, t, q, w, out)


@njit(cache=True, error_model="numpy", inline="always")
def torque_eval(kind, P, T, t, q, w, out):
    """Body-frame torque [N m] of the model ``(kind, P, T)`` at time ``t`` [s], attitude ``q`` [w, x, y, z]
    (body -> world, normalised here) and body rate ``w`` [rad/s]; written into ``out`` (3,). Inlined into the
    integrators' stage derivatives."""
    if kind == FREE:
        out[0] = 0.0
        out[1] = 0.0
        out[2] = 0.0
    elif kind == CONSTANT:
        out[0] = P[VECTOR]
        out[1] = P[VECTOR + 1]
        out[2] = P[VECTOR + 2]
    else:  # MAGNETIC, GRAVITY_GRADIENT, WHEELS, SUM: one call, so that the stage derivatives it is inlined into stay
        field_torque(kind, P, T, t, q, w, out)  # small


@njit(cache=True, error_model="numpy", inline="always")
def torque_needs_attitude(kind, P):
    """Whether the model's torque depends on the attitude (kernels skip computing it otherwise): the field is
    given in world components. (The same answer as the Python side's ``attitude_dependent``: both read the
    field's declared frame.)"""
    if kind == MAGNETIC:
        return P[FRAME] == WORLD
    return kind == GRAVITY_GRADIENT or (kind == SUM and P[1] != 0.0)  # a sum says it in its header (no loop here)


@njit(cache=True, error_model="numpy", inline="always")
def torque_needs_rate(kind, P):
    """Whether the model's torque depends on the body rate: a gyrostat's wheels, alone or in a sum (the splitting
    methods' last half kick is then implicit in the rate, else one evaluation)."""
    if kind == WHEELS:
        return True
    if kind == SUM:
        for i in range(int(P[0])):
            if int(P[2 + 3 * i]) == WHEELS:
                return True
    return False


@njit(cache=True, error_model="numpy")
def torque_many(kind, P, T, t, q, w, out):
    """:func:`torque_eval` at every row: times ``t`` (n,), attitudes ``q`` (n, 4), rates ``w`` (n, 3) -> ``out``
    (n, 3); the same arithmetic as the integrators' stages, for a run's samples or an engine's held inputs."""
    for i in range(t.shape[0]):
        torque_eval(kind, P, T, t[i], q[i], w[i], out[i])
