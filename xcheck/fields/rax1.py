"""The RAX-1 set-up of seed 004 §3.2: the thesis's initial torque and the synthetic body-frame field table."""

from __future__ import annotations

import numpy as np

from .kernel import MU0
from .models import magnetic_torque
from .orbit import OrbitDipoleField
from .tables import write_field_table

#: Seed 004 eq. 177: the thesis's initial torque [N m] (4 printed digits; not exactly perpendicular to M_p).
SEED004_INITIAL_TORQUE = np.array([-0.0012, 0.2166, -0.0038]) * 1e-4


def nearest_achievable_torque(dipole, torque) -> tuple[np.ndarray, float]:
    """The torque ``mu0 M x H`` (perpendicular to M) nearest to ``torque``, and the distance [N m]."""
    m = np.asarray(dipole, dtype=float)
    mhat = m / np.linalg.norm(m)
    along = float(np.dot(torque, mhat))
    return np.asarray(torque, float) - along * mhat, abs(along)


def rax1_synthetic_body_table(dipole=(0.14, 0.02, 1.09), *, duration: float = 500.0, spacing: float = 0.5,
                              B0_tesla: float = 35e-6) -> np.ndarray:
    """A smooth synthetic body-frame field for RAX-1 (the flight data of seed 004 Fig. 7 is not available).

    At t = 0 it gives the torque nearest to the thesis's eq. 177 that a dipole torque can be (the
    printed one has a 2.0e-9 N m component along M_p, a 4-digit rounding); the field's component along
    M_p, free in that fit, is chosen positive (the permanent magnet aligns with the field) so that
    |B(0)| = ``B0_tesla`` (35 µT, a LEO value). Then the perpendicular part turns about M_p once every
    250 s (the body's slow spin) with its size varying by ±15 % (400 s period) and the parallel part by
    ±10 % (600 s period): |B| stays within 32-39 µT. Rows every ``spacing`` s, so that the knots fall on
    step boundaries of every step 1/2, 1/4, ... s: the linear interpolation is then smooth within each
    step and RK4 keeps its order 4.
    """
    m = np.asarray(dipole, dtype=float)
    mhat = m / np.linalg.norm(m)
    tau, _ = nearest_achievable_torque(m, SEED004_INITIAL_TORQUE)
    H_perp0 = np.cross(tau, m) / (MU0 * np.dot(m, m))  # mu0 m x H_perp0 = tau
    H_total = B0_tesla / MU0
    H_par0 = np.sqrt(H_total**2 - np.dot(H_perp0, H_perp0))
    t = np.arange(0.0, duration + spacing / 2, spacing)
    phi = 2 * np.pi * t / 250.0
    # Rodrigues rotation of H_perp0 (perpendicular to mhat) about mhat by phi
    rotated = (np.cos(phi)[:, None] * H_perp0 + np.sin(phi)[:, None] * np.cross(mhat, H_perp0))
    H = (1 + 0.15 * np.sin(2 * np.pi * t / 400.0))[:, None] * rotated + \
        (H_par0 * (1 + 0.10 * np.sin(2 * np.pi * t / 600.0)))[:, None] * mhat
    return np.column_stack([t, H])


RAX1_TABLE_HEADER = (
    "RAX-1 body-frame magnetic field strength H [A/m] for seed 004 §3 (xcheck).",
    "SYNTHETIC: the RAX-1 flight magnetometer data of the thesis (Fig. 7) is not available to us.",
    "Made by xcheck.fields.write_rax1_body_table(): at t = 0 the torque mu0 M_p x H with",
    "M_p = [0.14, 0.02, 1.09] A m^2 is the achievable torque nearest to the thesis eq. 177",
    "[-0.0012, 0.2166, -0.0038]e-4 N m (2.0e-9 N m away: the printed value has that component along M_p);",
    "the component of H along M_p is chosen so that |B(0)| = 35 uT. Then H turns about M_p every 250 s and",
    "varies slowly: |B| stays within 32-39 uT, a LEO field. Rows every 0.5 s over 0-500 s (knots on the",
    "steps of every dt = 1/2^k s, so linear interpolation keeps RK4 at order 4). Columns: t [s], Hx, Hy, Hz [A/m].",
)


def write_rax1_body_table(path) -> None:
    """(Re)write the bundled ``models/rax1_field_body.csv``."""
    write_field_table(path, rax1_synthetic_body_table(), RAX1_TABLE_HEADER)


def rax1_orbit_phase_residual(field=None, dipole=(0.14, 0.02, 1.09), q0=(-0.4583, -0.6558, 0.5997, 0.0182)):
    """The torque at t = 0 of the orbit field with seed 004's printed attitude and dipole, its distance to
    eq. 177 [N m], and |B(0)| [T]."""
    from .. import rotations as rot

    field = field or OrbitDipoleField()
    H_body = rot.quat_rotate(rot.quat_conj(rot.quat_normalize(q0)), field.H_world(np.array([0.0]))[0])
    torque = magnetic_torque(dipole, H_body)
    return torque, float(np.linalg.norm(torque - SEED004_INITIAL_TORQUE)), float(MU0 * np.linalg.norm(H_body))
