"""``scipy-rk45``: what seed 001's script did — scipy's RK45 on ``[q, omega]`` (at ``solve_ivp``'s default
tolerances, rtol 1e-3 and atol 1e-6, unless told otherwise), sampled on the output grid from its dense output,
quaternion not normalised (its norm drift is part of the result). Its effort is bounded like the references'
(:func:`xcheck.reference.solve_bounded`): a run over budget is a failed run that says so."""

from __future__ import annotations

import numpy as np
from scipy.integrate import RK45

from ..reference import ReferenceFailure, rigid_body_rhs, solve_bounded
from ..trajectory import Trajectory, continuous_quaternions


def integrate_scipy_rk45(I, q0, omega0, t, torque, dt, *, rtol: float = 1e-3, atol: float = 1e-6) -> Trajectory:
    counted = [0]
    rhs = rigid_body_rhs(I, torque)

    def fun(tt, y):
        counted[0] += 1
        return rhs(tt, y)

    try:
        sol = solve_bounded(RK45, fun, np.concatenate([q0, omega0]), float(t[-1]), rtol=rtol, atol=atol,
                            what="scipy-rk45")
    except ReferenceFailure as exc:
        return Trajectory(t=t[:1], q=q0[None, :].copy(), omega=omega0[None, :].copy(), method="scipy-rk45", dt=dt,
                          status="failed", message=str(exc))
    y = sol(t).T
    return Trajectory(t=t, q=continuous_quaternions(y[:, :4]), omega=y[:, 4:].copy(), method="scipy-rk45", dt=dt,
                      extras={"evaluations": counted[0], "tolerances": (rtol, atol)})
