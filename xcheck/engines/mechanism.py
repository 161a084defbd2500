"""A scenario's body as the engines that build their own models assemble it (issue 40): a free body, a top on a ball
joint, or a gyrostat (a bus with wheels on hinges), from the MJCF's numbers (:class:`xcheck.models.MJCFBody`) and
the run's inertia (a sweep's moments included). PyBullet, DART, Drake and EXUDYN build each from this, with their own
joints, so that each engine's own joint dynamics and gravity are what is checked, as MuJoCo's are.

* A **top** (:class:`Top`): the body on a ball joint at the pivot (the world's origin), its centre of mass ``centre``
  from the pivot (body frame), its inertia about that centre, the model's gravity (world frame).
* A **gyrostat** (:class:`Gyrostat`): the bus and its wheels, each an axisymmetric body on a hinge along its axis
  through the common centre of mass. Only each wheel's axial moment enters the attitude dynamics (a balanced wheel's
  transverse inertia turns with the bus): a wheel is given the least transverse moment a real disc has, half its axial
  one, and the bus the rest of the whole body's inertia; each wheel 1 % of the mass (translation is not compared).
  A motor's pulse is a torque about the wheel's hinge, the bus taking its reaction through the joint.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Top", "Gyrostat", "EngineWheel", "mechanism_of", "pulse_torque", "WHEEL_MASS_FRACTION", "joint_kinds",
           "model_text"]

#: Each wheel's share of the body's mass (at the common centre of mass: the attitude does not feel it).
WHEEL_MASS_FRACTION = 0.01


@dataclass(frozen=True)
class Top:
    """A top on a ball joint at the world's origin: ``mass`` [kg], ``centre`` (3,) [m] of mass from the pivot (body
    frame), ``inertia`` (3, 3) [kg m^2] about the centre of mass (body frame), ``gravity`` (3,) [m/s^2] (world)."""

    mass: float
    centre: np.ndarray
    inertia: np.ndarray
    gravity: np.ndarray

    @property
    def about_pivot(self) -> np.ndarray:
        """The inertia about the pivot (body frame)."""
        c = self.centre
        return self.inertia + self.mass * (c @ c * np.eye(3) - np.outer(c, c))


@dataclass(frozen=True)
class EngineWheel:
    """One wheel: its hinge ``axis`` (unit, body frame), ``axial`` and ``transverse`` moments [kg m^2], ``mass`` [kg],
    initial ``speed`` relative to the bus [rad/s], and its motor's ``pulse`` ``(peak [N m], t0, t1)`` or None."""

    axis: np.ndarray
    axial: float
    transverse: float
    mass: float
    speed: float
    pulse: tuple | None

    @property
    def inertia(self) -> np.ndarray:
        """The wheel's inertia tensor about its centre, body frame."""
        a = self.axis
        return self.transverse * (np.eye(3) - np.outer(a, a)) + self.axial * np.outer(a, a)


@dataclass(frozen=True)
class Gyrostat:
    """A bus of ``mass`` [kg] and ``inertia`` (3, 3) [kg m^2] about the common centre of mass (body frame), without
    its wheels (:class:`EngineWheel`, on hinges through that centre)."""

    mass: float
    inertia: np.ndarray
    wheels: tuple


def pulse_torque(wheel: EngineWheel, t: float) -> float:
    """The torque [N m] a wheel's motor exerts about its hinge at ``t`` (0 without a motor): the pulse
    ``peak sin^2(pi (t - t0) / (t1 - t0))`` on ``[t0, t1]`` (:func:`xcheck.fields.kernel.pulse`)."""
    if wheel.pulse is None:
        return 0.0
    from ..fields.kernel import pulse

    peak, t0, t1 = wheel.pulse
    return float(pulse(peak, t0, t1, float(t))[1])


def mechanism_of(ctx) -> Top | Gyrostat | None:
    """What an engine builds for the run context ``ctx`` (:class:`xcheck.runners.RunContext`): a :class:`Top`, a
    :class:`Gyrostat`, or None for a free body (its inertia ``ctx.inertia``, as before)."""
    body = getattr(ctx, "body", None)
    if body is None:
        return None
    inertia = np.asarray(ctx.inertia, dtype=float)
    if getattr(body, "joint", "free") == "ball":
        c = np.asarray(body.centre, dtype=float)
        return Top(float(body.mass), c, inertia - body.mass * (c @ c * np.eye(3) - np.outer(c, c)),
                   np.asarray(body.gravity, dtype=float))
    if not body.wheels:
        return None
    speeds = body.wheel_speeds0(ctx.wheel_speeds)
    wheels = []
    for w, speed in zip(body.wheels, speeds):
        a = np.asarray(w.axis, dtype=float)
        wheels.append(EngineWheel(a / np.linalg.norm(a), float(w.moment), 0.5 * float(w.moment),
                                  WHEEL_MASS_FRACTION * float(body.mass), float(speed), w.pulse))
    bus = inertia - sum(w.transverse * (np.eye(3) - np.outer(w.axis, w.axis)) for w in wheels)
    moments = np.linalg.eigvalsh(bus)
    if moments[0] <= 0 or 2 * moments.max() > moments.sum() * (1 + 1e-12):
        raise ValueError(f"{body.path}: the bus without its wheels' transverse moments (half their axial ones) has "
                         f"principal moments {moments.tolist()} kg m^2, not a rigid body's (each at most the sum of "
                         "the others)")
    return Gyrostat(float(body.mass) * (1 - WHEEL_MASS_FRACTION * len(wheels)), bus, tuple(wheels))


def model_text(model) -> str | None:
    """An MJCF's text without its comments, read so that planning a study (the pytest plugin's collection) imports no
    MuJoCo; None when it cannot be read (said where the model is loaded for the run)."""
    import re
    from pathlib import Path

    try:
        return re.sub(r"<!--.*?-->", "", Path(model).read_text(encoding="utf-8", errors="replace"), flags=re.S)
    except OSError:
        return None


def joint_kinds(model) -> set:
    """The kinds of joint an MJCF declares besides the free joint (``ball``, ``hinge``: a top's pivot, a gyrostat's
    wheels), read from its text (:func:`model_text`)."""
    import re

    text = model_text(model)
    if text is None:
        return set()
    kinds = set()
    for tag in re.findall(r"<joint\b[^>]*>", text):
        m = re.search(r"\btype\s*=\s*[\"'](\w+)[\"']", tag)
        kinds.add(m.group(1) if m else "hinge")  # MJCF's default joint type is a hinge
    return kinds - {"free"}
