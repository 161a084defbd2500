"""``scipy-rk45``: what seed 001's script did — scipy ``solve_ivp`` RK45 at its default tolerances
(rtol 1e-3, atol 1e-6) on ``[q, omega]``, sampled on the study's grid (``t_eval``), quaternion not
normalised (its norm drift is part of the result)."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from ..reference import rigid_body_rhs
from ..trajectory import Trajectory, continuous_quaternions


def integrate_scipy_rk45(I, q0, omega0, t, torque, dt) -> Trajectory:
    sol = solve_ivp(rigid_body_rhs(I, torque), (0.0, float(t[-1])), np.concatenate([q0, omega0]), method="RK45",
                    t_eval=t)
    n = sol.y.shape[1]
    traj = Trajectory(t=sol.t, q=continuous_quaternions(sol.y[:4].T), omega=sol.y[4:].T.copy(), method="scipy-rk45",
                      dt=dt, extras={"rhs_evaluations": int(sol.nfev)})
    if sol.status != 0 or n != len(t):
        traj.status = "failed"
        traj.message = f"scipy-rk45: solve_ivp stopped at t = {sol.t[-1] if n else 0.0:.6g} s: {sol.message}"
    return traj
