"""The full IGRF field (``ppigrf``, optional extra ``igrf``) along the circular orbit, tabulated."""

from __future__ import annotations

import numpy as np

from .kernel import MU0
from .models import Key, WorldFieldTable
from .orbit import OMEGA_EARTH, ORBIT_KEYS, RAX1_ORBIT, orbit_position


class IGRFField(WorldFieldTable):
    """The IGRF model along the circular orbit of :class:`~xcheck.fields.OrbitDipoleField` at ``epoch``,
    tabulated in inertial components every ``spacing`` s and linearly interpolated."""

    name = "igrf"
    keys = {**ORBIT_KEYS, "epoch": Key("string", help="ISO date, default 2010-11-20T00:00:00")}

    def __init__(self, *, duration: float, epoch: str = "2010-11-20T00:00:00", spacing: float = 0.5,
                 altitude_km: float = RAX1_ORBIT["altitude_km"], inclination_deg: float = RAX1_ORBIT["inclination_deg"],
                 raan_deg: float = RAX1_ORBIT["raan_deg"], arg_latitude_deg: float = RAX1_ORBIT["arg_latitude_deg"],
                 earth_angle_deg: float = RAX1_ORBIT["earth_angle_deg"]):
        try:
            import ppigrf
        except ImportError:
            raise ValueError("field 'igrf' needs the optional extra: pip install 'xcheck[igrf]'") from None
        from datetime import datetime

        try:
            date = datetime.fromisoformat(str(epoch))
        except ValueError:
            raise ValueError(f"epoch: expected an ISO date like 2010-11-20T00:00:00, got {epoch!r}") from None
        g, _ = ppigrf.ppigrf.read_shc()  # the coefficients' span: ppigrf extrapolates beyond it, and prints on stdout
        first, last = g.index[0].to_pydatetime(), g.index[-1].to_pydatetime()
        if not first <= date <= last:
            raise ValueError(f"epoch: {epoch!r} is outside the IGRF coefficients' span, {first.date()} to "
                             f"{last.date()}: give a date within it")
        t = np.arange(0.0, float(duration) + spacing, spacing)
        r_eci = orbit_position(t, altitude_km, inclination_deg, raan_deg, arg_latitude_deg)
        g = np.radians(earth_angle_deg) + OMEGA_EARTH * t
        cg, sg = np.cos(g), np.sin(g)
        x, y, z = cg * r_eci[:, 0] + sg * r_eci[:, 1], -sg * r_eci[:, 0] + cg * r_eci[:, 1], r_eci[:, 2]  # ECEF
        r = np.linalg.norm(r_eci, axis=1)
        theta = np.arccos(z / r)
        phi = np.arctan2(y, x)
        Br, Bth, Bph = ppigrf.igrf_gc(r / 1e3, np.degrees(theta), np.degrees(phi), date)  # [nT]
        Br, Bth, Bph = (np.asarray(b, dtype=float).reshape(-1) * 1e-9 for b in (Br, Bth, Bph))
        st, ct, sp, cp = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
        Bx = Br * st * cp + Bth * ct * cp - Bph * sp
        By = Br * st * sp + Bth * ct * sp + Bph * cp
        Bz = Br * ct - Bth * st
        B_eci = np.stack([cg * Bx - sg * By, sg * Bx + cg * By, Bz], axis=1)
        super().__init__(np.column_stack([t, B_eci / MU0]), source=f"IGRF at {epoch}")

    @classmethod
    def from_keys(cls, values, *, duration):
        return cls(duration=duration, **values)
