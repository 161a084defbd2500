"""One run of one method on a scenario, measured against its reference (``xcheck run``): the trajectory, its wall
time, and its attitude error on its own grid. The study's context and reference, without the study."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .. import rotations as rot
from ..reference import ReferenceFailure
from ..scenario import Scenario
from ..trajectory import Trajectory
from . import context

__all__ = ["SingleRun", "run_once"]


@dataclass
class SingleRun:
    """What :func:`run_once` found: the trajectory and its wall time [s]; ``error`` the attitude error [rad] at
    each of its times (NaN where the reference is not defined, or everywhere without one); ``rate_error`` the
    body-rate error [rad/s] at the end (None without a reference there); ``no_reference`` why there is none."""

    scenario: Scenario
    method: str
    dt: float
    traj: Trajectory
    wall_time: float
    error: np.ndarray
    rate_error: float | None = None
    no_reference: str | None = None

    @property
    def measured_at_end(self) -> bool:
        """Whether the run completed and the reference is defined at its last time."""
        return self.traj.ok and len(self.error) > 0 and bool(np.isfinite(self.error[-1]))

    @property
    def max_error(self) -> float:
        """The largest attitude error [rad] over the times the reference is defined (NaN without one)."""
        return float(np.nanmax(self.error)) if np.any(np.isfinite(self.error)) else float("nan")

    @property
    def ok(self) -> bool:
        """The run completed and there is a reference to say how well (``xcheck run``'s exit 0)."""
        return self.traj.ok and self.no_reference is None


def run_once(scenario: Scenario, runner, dt: float, rtol: float | None = None) -> SingleRun:
    """``runner`` on ``scenario`` at ``dt`` (and ``rtol``, an adaptive method's), measured against the
    scenario's reference."""
    ctx = context.run_context(scenario)
    t0 = time.perf_counter()
    traj = runner.run_at(ctx, dt, rtol)
    wall = time.perf_counter() - t0
    error = np.full(len(traj.t), np.nan)
    try:
        ref = context.scenario_reference(scenario)
    except ReferenceFailure as exc:
        return SingleRun(scenario, runner.name, dt, traj, wall, error, no_reference=str(exc))
    q_ref, w_ref, mask = ref.at(traj.t)
    error = np.where(mask, rot.attitude_error(traj.q, q_ref), np.nan)
    rate = float(np.linalg.norm(traj.omega[-1] - w_ref[-1])) if len(mask) and mask[-1] and traj.ok else None
    return SingleRun(scenario, runner.name, dt, traj, wall, error, rate_error=rate)
