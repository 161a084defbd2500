"""MJCF models: load the one moving rigid body of the cross-check, refusing what is out of scope.

The body turns on a free joint (torque free but for what a scenario applies; its inertia about its centre of
mass) or on a ball joint (a heavy top: its inertia about the pivot, the model's gravity a torque about it); child
bodies without joints of their own are welded to it (bodies built from parts). The MJCF is the single source of
truth for every engine: the inertia (``<inertial>``, any orientation), the mass and the permanent magnetic dipole,
stored as ``<custom><numeric name="xcheck_dipole" data="mx my mz"/></custom>`` [A m^2] in body components.
"""

from __future__ import annotations

import copy
import math
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import mujoco
import numpy as np

from . import rotations as rot
from .base.errors import UserError
from .body import MAX_GRAVITY, MAX_RATE, RigidBody
from .paths import input_problem, xml_root
from .trajectory import check_initial_state

__all__ = ["ModelError", "MJCFBody", "Wheel", "load_body", "load_mujoco", "composite_inertia", "initial_state", "InitialState", "DEFAULT_RATE",
           "DIPOLE_NUMERIC"]

#: The name of the ``<custom><numeric>`` that holds the permanent dipole [A m^2].
DIPOLE_NUMERIC = "xcheck_dipole"


class ModelError(UserError):
    """An MJCF file that xcheck cannot use; the message names the file and the reason."""


#: The prefix of the ``<custom><numeric>`` that gives a motor its command: ``xcheck_pulse:<actuator name>`` with
#: ``data="peak t0 t1"``, a torque pulse ``peak sin^2(pi (t - t0) / (t1 - t0))`` [N m] on the wheel over
#: ``[t0, t1]`` [s] (:func:`xcheck.fields.kernel.pulse`); a motor without one exerts nothing.
PULSE_NUMERIC = "xcheck_pulse:"
#: What a gyrostat may drive its wheels with (the refusal of any other actuator names them).
ALLOWED_ACTUATORS = ("a <motor> (or a <general> with a fixed gain and no bias or dynamics) on a wheel's hinge, "
                     "commanded by a <numeric name=\"xcheck_pulse:ACTUATOR\" data=\"peak t0 t1\"/> torque pulse")


@dataclass(frozen=True)
class Wheel:
    """An axisymmetric wheel of a gyrostat (issue 28): a child body on a hinge whose axis passes through its centre
    of mass. ``axis``: the hinge axis (unit, the free body's frame); ``moment``: its axial moment of inertia
    [kg m^2]; ``dof``/``qpos``: its hinge's ``qvel``/``qpos`` address; ``actuator``: the motor driving it (-1:
    none) and ``gain``, the torque [N m] a unit ``ctrl`` exerts on the wheel; ``pulse``: its command ``(peak, t0,
    t1)`` (None: a free wheel); ``speed``: its speed relative to the body [rad/s] in the model's first keyframe
    (0 without one); ``body``: its body's id."""

    name: str
    axis: tuple
    moment: float
    dof: int
    qpos: int
    body: int = -1
    actuator: int = -1
    gain: float = 1.0
    pulse: tuple | None = None
    speed: float = 0.0


@dataclass(frozen=True)
class MJCFBody(RigidBody):
    """A :class:`~xcheck.body.RigidBody` read from an MJCF file, with where it came from.

    ``notes`` lists what was changed to bring the model into scope (e.g. gravity switched off);
    ``body_id``, ``qpos_adr`` and ``dof_adr`` locate the free body in the MuJoCo model; ``model_moments`` and
    ``model_iquat`` are its principal moments and principal frame as MuJoCo compiled them (``body_inertia``,
    ``body_iquat``): what a sweep's inertia axis replaces or scales.
    """

    path: str = ""
    notes: tuple = ()
    body_id: int = 1
    qpos_adr: int = 0
    dof_adr: int = 0
    model_moments: tuple = ()
    model_iquat: tuple = (1.0, 0.0, 0.0, 0.0)
    #: ``"free"`` (the inertia about the centre of mass) or ``"ball"`` (a heavy top: the inertia about the pivot)
    joint: str = "free"
    #: ball joint: the centre of mass from the pivot [m], body frame (zero on a free joint)
    centre: tuple = (0.0, 0.0, 0.0)
    #: ball joint: the model's gravity [m/s^2], world frame (a free body's is switched off: zero)
    gravity: tuple = (0.0, 0.0, 0.0)
    #: ball joint: the body's world attitude at the joint's ``qpos`` = identity (its reference orientation, the
    #: MJCF's ``quat`` and its parents'): the world attitude is ``reference_quat ⊗ qpos``
    reference_quat: tuple = (1.0, 0.0, 0.0, 0.0)
    #: a gyrostat's wheels (:class:`Wheel`); its ``inertia`` is then the whole body's about the common centre of mass
    #: less each wheel's axial moment about its axis (what :class:`~xcheck.fields.WheelsTorque` goes with)
    wheels: tuple = ()
    #: how many MJCF bodies are welded into this one (a body built from parts: more than 1)
    parts: int = 1
    #: the model's own step [s] (``<option timestep>``, MuJoCo's default 0.002 s where the file sets none) and
    #: integrator (``<option integrator>``, as xcheck's method names it: ``euler``, ``rk4``, ``implicit``,
    #: ``implicitfast``), and whether the file writes the step: the user's step a study anchors on (issue 59)
    timestep: float = 0.002
    integrator: str = "euler"
    timestep_written: bool = False

    @property
    def step_source(self) -> str:
        """Where :attr:`timestep` comes from, in words."""
        return ("the model's <option timestep>" if self.timestep_written
                else "MuJoCo's default step: the MJCF sets no <option timestep>")

    def inertia_with(self, moments) -> np.ndarray:
        """The body-frame inertia tensor with ``moments`` (about the centre of mass) in place of
        :attr:`model_moments` (same axes), about the point the body turns about."""
        R = rot.quat_to_dcm(np.asarray(self.model_iquat, dtype=float))
        return R @ np.diag(np.asarray(moments, dtype=float)) @ R.T + _parallel_axes(self.mass, self.centre)

    def inertia_for(self, moments=None) -> np.ndarray:
        """The inertia a run uses: the model's, or :meth:`inertia_with` a sweep's ``moments`` (None: the model's)."""
        return self.inertia if moments is None else self.inertia_with(moments)

    def mass_inertia(self, moments=None) -> np.ndarray:
        """The inertia of the whole mass, wheels included (what a gravity gradient pulls on): :meth:`inertia_for`
        plus each wheel's axial moment about its axis (a gyrostat's dynamics take it less those)."""
        out = self.inertia_for(moments)
        for w in self.wheels:
            out = out + w.moment * np.outer(w.axis, w.axis)
        return out

    def own_torque(self, omega0=None, wheel_speeds=None):
        """The torque the model itself exerts on the body (None: none): on a ball joint, gravity's about the pivot
        (:class:`~xcheck.fields.GravityTorque`, evaluated at every stage like any attitude-dependent torque); a
        gyrostat's wheels' (:class:`~xcheck.fields.WheelsTorque`), whose momentum is set by the body rate
        ``omega0`` and the wheels' speeds relative to it (None: the model's, :attr:`Wheel.speed`)."""
        if self.wheels:
            return self.wheels_torque(omega0, wheel_speeds)
        if self.joint != "ball" or not np.any(self.gravity) or not np.any(self.centre):
            return None
        from .fields import GravityTorque

        return GravityTorque(self.centre, self.mass, self.gravity)

    def wheel_speeds0(self, wheel_speeds=None) -> np.ndarray:
        """The wheels' initial speeds relative to the body [rad/s]: ``wheel_speeds`` (one per wheel, in the MJCF's
        order), or the model's own (:attr:`Wheel.speed`)."""
        if wheel_speeds is None:
            return np.array([w.speed for w in self.wheels], dtype=float)
        speeds = np.asarray(wheel_speeds, dtype=float)
        if speeds.shape != (len(self.wheels),) or not np.all(np.abs(speeds) <= MAX_RATE):
            raise ValueError(f"wheel_speeds: expected {len(self.wheels)} finite speeds [rad/s] of at most "
                             f"{MAX_RATE:.0e} (one per wheel of {self.path}: {', '.join(w.name for w in self.wheels)}), "
                             f"got {np.ravel(speeds).tolist()}")
        return speeds

    def wheels_torque(self, omega0, wheel_speeds=None):
        """:class:`~xcheck.fields.WheelsTorque` of the wheels from the body rate ``omega0`` [rad/s] and their
        speeds: each wheel's absolute axial momentum ``p_i = J_s (a_i . w0 + Omega_i)``, and each motor's pulse."""
        from .fields import WheelsTorque

        w0 = np.zeros(3) if omega0 is None else np.asarray(omega0, dtype=float)
        speeds = self.wheel_speeds0(wheel_speeds)
        h0, commands, wheels = np.zeros(3), [], []
        for wheel, speed in zip(self.wheels, speeds):
            a = np.asarray(wheel.axis, dtype=float)
            p0 = wheel.moment * (a @ w0 + speed)
            h0 += p0 * a
            index = None
            if wheel.pulse is not None:
                index = len(commands)
                commands.append((a, *wheel.pulse))
            wheels.append((a, wheel.moment, p0, index))
        return WheelsTorque(h0, commands, wheels=wheels)

    def to_joint(self, q) -> np.ndarray:
        """The joint's ``qpos`` quaternion(s) of world attitude(s) ``q`` (a free joint's is the attitude itself)."""
        if self.joint == "free":
            return np.asarray(q, dtype=float)
        return rot.quat_mul(rot.quat_conj(np.asarray(self.reference_quat, dtype=float)), q)

    def from_joint(self, qpos) -> np.ndarray:
        """World attitude(s) of the joint's ``qpos`` quaternion(s) (inverse of :meth:`to_joint`)."""
        if self.joint == "free":
            return np.asarray(qpos, dtype=float)
        return rot.quat_mul(np.asarray(self.reference_quat, dtype=float), qpos)

    @property
    def quat_slice(self) -> slice:
        """Where the joint's quaternion sits in ``qpos`` (a free joint's after its position)."""
        a = self.qpos_adr + (3 if self.joint == "free" else 0)
        return slice(a, a + 4)

    @property
    def rate_slice(self) -> slice:
        """Where the body-frame angular velocity sits in ``qvel``."""
        a = self.dof_adr + (3 if self.joint == "free" else 0)
        return slice(a, a + 3)


def _parallel_axes(mass: float, d) -> np.ndarray:
    """``m (|d|^2 E - d d^T)``: what the inertia about a point ``d`` from the centre of mass adds."""
    d = np.asarray(d, dtype=float)
    return mass * (d @ d * np.eye(3) - np.outer(d, d))


def load_body(path) -> MJCFBody:
    """The rigid body of an MJCF file (see :func:`load_mujoco`)."""
    return load_mujoco(path)[1]


def load_mujoco(path) -> tuple[mujoco.MjModel, MJCFBody]:
    """Compile an MJCF file and check it is one free rigid body.

    Refused (:class:`ModelError` naming the file and the reason): a parse or compile error (MuJoCo's
    message, with its line), no free joint, any other joint, more than one moving body, equality
    constraints, actuators, tendons, plugins, flexes, possible contacts, fluid forces (density or viscosity),
    stiffness, damping, armature or friction loss on the free joint. Gravity is switched off instead, with a note: a uniform field
    exerts no torque about the centre of mass, so the attitude motion is unchanged.

    Returns the prepared :class:`mujoco.MjModel` (a copy of its own, free to change) and the :class:`MJCFBody`.
    A file is compiled once per process while it is unchanged (a study runs MuJoCo hundreds of times on it).
    """
    path = Path(path)
    where = str(path)
    problem = input_problem(path, "MJCF file")
    if problem:
        raise ModelError(problem)
    stat = path.stat()
    key = (str(path.resolve()), where, stat.st_mtime_ns, stat.st_size)
    if key not in _LOADED:
        if len(_LOADED) > 32:
            _LOADED.clear()
        _LOADED[key] = _load_mujoco(path, where)
    model, body = _LOADED[key]
    for note in body.notes:
        warnings.warn(f"{where}: {note}", stacklevel=1)  # from this module: what the commands filter by
    return copy.copy(model), body


_LOADED: dict = {}


@dataclass(frozen=True)
class InitialState:
    """The rotational initial state an MJCF file holds: ``q0`` (body -> world) and ``omega0`` [rad/s] (body
    frame; the quaternion as the model holds it, normalised where the scenario is read), where they came from
    (``source``), the keyframe's name (None: the model's own pose), the names of
    every keyframe it has, and what xcheck leaves out (``notes``: a translation, other joints' values)."""

    q0: np.ndarray
    omega0: np.ndarray
    source: str
    keyframe: str | None
    keyframes: tuple
    notes: tuple = ()
    body: MJCFBody | None = None  # the body the state is of, as load_body reads it
    #: a gyrostat's wheels' speeds relative to the body [rad/s] (the keyframe's; zero without one)
    wheel_speeds: tuple = ()


#: The keyframe name that asks for the model's own pose at :data:`DEFAULT_RATE` (``xcheck init --keyframe none``,
#: ``MODEL.xml#none``), unless the model has a keyframe of that name.
NO_KEYFRAME = "none"
#: The body rate [rad/s], body frame, of a model that has no keyframe: about every axis, the largest about the
#: third, so that a torque-free study exercises the full Euler equations (stated in the report).
DEFAULT_RATE = (0.1, 0.5, 1.0)


def initial_state(path, keyframe: str | None = None) -> InitialState:
    """The initial state of the free body of an MJCF file: its keyframe ``keyframe`` (by name), else its first
    keyframe, else the model's own pose (``qpos0``, the body's ``pos``/``quat`` in the MJCF) at
    :data:`DEFAULT_RATE`. A free joint's ``qpos`` holds the quaternion [w, x, y, z] body -> world at 3..6 and its
    ``qvel`` the body-frame angular velocity at 3..5 (what :mod:`xcheck.engines.mujoco` writes and reads).
    :class:`ModelError` naming the file for a keyframe it does not have, or one whose quaternion is zero."""
    model, body = load_mujoco(path)
    where = str(path)
    names = tuple(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, k) or f"#{k}" for k in range(model.nkey))
    da, qs, ws = body.dof_adr, body.quat_slice, body.rate_slice
    own_pose = keyframe == NO_KEYFRAME and NO_KEYFRAME not in names  # "none": the model's own pose, a default rate
    if keyframe is not None and not own_pose and keyframe not in names:
        have = f"its keyframes: {', '.join(names)}" if names else "it has no <keyframe>"
        raise ModelError(f"{where}: no keyframe named {keyframe!r} ({have}); {NO_KEYFRAME!r} asks for the body's own "
                         "pose at the default rate")
    if not names or own_pose:
        q0 = body.from_joint(np.asarray(model.qpos0[qs], dtype=float))
        return InitialState(q0, np.asarray(DEFAULT_RATE, dtype=float),
                            f"{'no <keyframe>' if not names else 'keyframe none asked for'}: the body's pose in the MJCF "
                            f"and the default body rate "
                            f"{list(DEFAULT_RATE)} rad/s (body frame)" + (", the wheels at rest relative to it"
                                                                          if body.wheels else ""),
                            None, names, body=body, wheel_speeds=tuple(0.0 for _ in body.wheels))
    k = names.index(keyframe) if keyframe is not None else 0
    qpos, qvel = model.key_qpos[k], model.key_qvel[k]
    q_joint = np.asarray(qpos[qs], dtype=float)
    written = _written_key_quaternion(path, k, qs)  # MuJoCo's compiler makes a zero one the identity, silently
    if written is not None:
        q_joint = written if not np.any(written) else q_joint
    if not np.all(np.isfinite(q_joint)) or np.linalg.norm(q_joint) == 0:
        raise ModelError(f"{where}: keyframe {names[k]!r}: the {body.joint} joint's quaternion {q_joint.tolist()} "
                         "cannot be normalised (MuJoCo's compiler would take the identity for it): give the attitude "
                         "as a unit quaternion [w x y z]")
    q0 = body.from_joint(q_joint / np.linalg.norm(q_joint)) if body.joint == "ball" else q_joint
    omega0 = np.asarray(qvel[ws], dtype=float)
    notes = []
    if body.joint == "free" and np.any(qvel[da:da + 3] != 0):
        notes.append(f"the keyframe's translational velocity {qvel[da:da + 3].tolist()} m/s is left out: xcheck "
                     "checks the attitude (the free body's translation does not change it)")
    if not np.any(omega0):
        notes.append("the keyframe's body rate is zero: the body does not turn, and every method is exact")
    which = f"keyframe {names[k]!r}" + (" (the first of the model's)" if keyframe is None and len(names) > 1 else "")
    speeds = tuple(float(qvel[w.dof]) for w in body.wheels)
    try:
        check_initial_state(q0, omega0)
    except ValueError as exc:
        raise ModelError(f"{where}: {which}: the {body.joint} joint's qvel, the body rate {omega0.tolist()} rad/s: "
                         f"{str(exc).partition(': ')[2]}") from None
    for w, speed in zip(body.wheels, speeds):
        if not abs(speed) <= MAX_RATE:
            raise ModelError(f"{where}: {which}: the qvel of wheel '{w.name}', {speed:g} rad/s: expected a finite "
                             f"speed of at most {MAX_RATE:.0e} rad/s")
    return InitialState(q0, omega0, f"the {which}: qpos and qvel of the {body.joint} joint"
                        + (" and of the wheels' hinges" if body.wheels else ""), names[k],
                        names, tuple(notes), body=body, wheel_speeds=speeds)


#: MuJoCo's integrators (``mjtIntegrator``) under the names of xcheck's methods (``mujoco-<name>``).
_INTEGRATORS = {int(mujoco.mjtIntegrator.mjINT_EULER): "euler", int(mujoco.mjtIntegrator.mjINT_RK4): "rk4",
                int(mujoco.mjtIntegrator.mjINT_IMPLICIT): "implicit",
                int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST): "implicitfast"}


def _writes_timestep(path) -> bool:
    """Whether the MJCF file writes ``<option timestep>`` itself (else the model runs at MuJoCo's default step)."""
    import xml.etree.ElementTree as ET

    try:
        return any(o.get("timestep") is not None for o in ET.parse(path).getroot().iter("option"))
    except (ET.ParseError, OSError):
        return False


def _written_key_quaternion(path, k: int, qs: slice) -> np.ndarray | None:
    """The quaternion slots ``qs`` of the ``k``-th ``<key>`` as written in the MJCF file itself (before MuJoCo's
    compiler normalises them), or None where the file does not say (a ``<key>`` in an included file, no ``qpos``)."""
    import xml.etree.ElementTree as ET

    try:
        keys = [key for frame in ET.parse(path).getroot().iter("keyframe") for key in frame.iter("key")]
        values = np.array(keys[k].get("qpos", "").split(), dtype=float)
    except (ET.ParseError, OSError, IndexError, ValueError):
        return None
    return values[qs] if len(values) >= qs.stop else None


def _load_mujoco(path: Path, where: str) -> tuple[mujoco.MjModel, MJCFBody]:
    """Load ``path`` with MuJoCo and read its one rigid body (the checks of :func:`load_model`), each step named:
    the joint that turns it, the forces xcheck would not model, gravity, the mass properties (one body, parts welded
    together, or a gyrostat's), the pivot of a top, the dipole."""
    root = xml_root(path)
    if root is not None and root != "mujoco":  # MuJoCo would read a URDF too, and build a robot of it
        what = "a URDF robot description (<robot>)" if root == "robot" else f"an XML file whose root is <{root}>"
        raise ModelError(f"{where}: {what}, not an MJCF model (<mujoco>): convert it with MuJoCo: m = "
                         "mujoco.MjModel.from_xml_path(FILE); mujoco.mj_saveLastXML('model.xml', m)")
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:  # MuJoCo's parse/compile error, which names the line
        raise ModelError(f"{where}: MuJoCo could not load it: {str(exc).strip()}") from None
    notes = []

    def refuse(reason):
        raise ModelError(f"{where}: {reason}")

    def name(obj, i):
        return mujoco.mj_id2name(model, obj, i) or f"#{i}"

    _check_finite(model, refuse, name)
    jnt, joint = _turning_joint(model, refuse, name)
    body_id = int(model.jnt_bodyid[jnt])
    body_name = name(mujoco.mjtObj.mjOBJ_BODY, body_id)
    # a part without a joint of its own (an axle, a panel, an antenna) is welded to it: one rigid body (a part with
    # a joint was refused above)
    parts = [b for b in range(1, model.nbody) if model.body_weldid[b] == body_id]
    if model.neq:
        refuse(f"{model.neq} equality constraint(s): out of scope (one free rigid body)")
    wheels = _wheels(model, body_id, joint, [j for j in range(model.njnt) if j != jnt], refuse, name)
    dof = int(model.jnt_dofadr[jnt])
    _refuse_other_forces(model, jnt, joint, refuse)
    gravity = _gravity(model, joint, parts, notes, refuse, name)
    mass, com, inertia, moments, iquat, wheels = _mass_properties(model, body_id, body_name, parts, wheels, notes)
    centre, reference = np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])
    if joint == "ball":  # a top: it turns about the pivot, where the joint is (body frame)
        centre = com - model.jnt_pos[jnt]
        inertia = inertia + _parallel_axes(mass, centre)
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)  # at qpos0: the ball joint's identity, the body at its reference pose
        reference = data.xquat[body_id].copy()
        notes.append(f"a top on the ball joint '{name(mujoco.mjtObj.mjOBJ_JOINT, jnt)}': inertia about the pivot, "
                     f"centre of mass {np.round(centre, 9).tolist()} m from it, gravity {gravity.tolist()} m/s^2 kept "
                     "(its torque about the pivot, c x m R^T g)")
    dipole = _dipole(model, refuse)
    try:
        body = MJCFBody(inertia=inertia, mass=float(mass), dipole=dipole,
                        name=body_name if not body_name.startswith("#") else path.stem, path=where,
                        notes=tuple(notes), body_id=body_id, qpos_adr=int(model.jnt_qposadr[jnt]), dof_adr=dof,
                        model_moments=tuple(moments.tolist()), model_iquat=tuple(np.asarray(iquat).tolist()),
                        joint=joint, centre=tuple(centre.tolist()), gravity=tuple(gravity.tolist()),
                        reference_quat=tuple(reference.tolist()), wheels=tuple(wheels), parts=len(parts),
                        timestep=float(model.opt.timestep), integrator=_INTEGRATORS.get(int(model.opt.integrator), ""),
                        timestep_written=_writes_timestep(path))
    except ValueError as exc:
        raise ModelError(f"{where}: body '{body_name}': {exc}") from None
    return model, body


def _turning_joint(model, refuse, name) -> tuple[int, str]:
    """The one free or ball joint that turns the body, and which it is; any other joint but a wheel's hinge refused."""
    turning = (int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_BALL))
    hinge = int(mujoco.mjtJoint.mjJNT_HINGE)
    roots = [j for j in range(model.njnt) if int(model.jnt_type[j]) in turning]
    robot = _multibody(model, roots, hinge)
    if robot:
        refuse(robot)
    for j in range(model.njnt):
        if int(model.jnt_type[j]) not in (*turning, hinge):
            kind = mujoco.mjtJoint(model.jnt_type[j]).name.removeprefix("mjJNT_").lower()
            refuse(f"joint '{name(mujoco.mjtObj.mjOBJ_JOINT, j)}' is a {kind} joint: only one free joint or one ball "
                   "joint is supported (and hinges of wheels on a free body)")
    if not roots:
        if model.njnt:
            refuse(f"joint '{name(mujoco.mjtObj.mjOBJ_JOINT, 0)}' is a hinge joint with no free body to carry it: "
                   "xcheck needs one body with <freejoint/> (or, for a top turning about a fixed point, a "
                   "<joint type=\"ball\"/>); a hinge is only a wheel's, on a child of the free body")
        refuse("no free joint: xcheck needs one body with <freejoint/> (or, for a top turning about a fixed point, "
               "a <joint type=\"ball\"/>)")
    if len(roots) > 1:
        refuse(f"{len(roots)} free or ball joints: more than one moving body (xcheck needs one free or one ball joint)")
    jnt = roots[0]
    joint = "free" if int(model.jnt_type[jnt]) == turning[0] else "ball"
    if joint == "ball" and model.jnt_limited[jnt]:
        refuse(f"the ball joint '{name(mujoco.mjtObj.mjOBJ_JOINT, jnt)}' has a range: a limit is a constraint "
               "force xcheck does not model; remove limited/range")
    return jnt, joint


def _refuse_other_forces(model, jnt: int, joint: str, refuse) -> None:
    """Refuse what would add a force xcheck does not model: the joint's damping, armature, friction or stiffness,
    tendons, plugins and flexes, fluid forces, contacts between the body's geoms."""
    dof = int(model.jnt_dofadr[jnt])
    ndof = 6 if joint == "free" else 3
    for what, values in (("damping", model.dof_damping), ("armature", model.dof_armature),
                         ("frictionloss", model.dof_frictionloss)):
        if np.any(values[dof:dof + ndof] != 0):
            refuse(f"the {joint} joint has {what} {values[dof:dof + ndof].tolist()}: it would change the rotational "
                   "dynamics; set it to 0")
    if model.jnt_stiffness[jnt] != 0:
        refuse(f"the {joint} joint has stiffness {model.jnt_stiffness[jnt]:g}: a spring pulling the body to its "
               "reference pose would add torque; set it to 0")
    if model.ntendon:
        refuse(f"{model.ntendon} tendon(s): their springs, damping and limits would add torque; remove the "
               "<tendon> section")
    for what, count in (("plugin", getattr(model, "nplugin", 0)), ("flex", getattr(model, "nflex", 0))):
        if count:
            refuse(f"{count} {what}(s): they can add forces xcheck does not model; remove them")
    if model.opt.density != 0 or model.opt.viscosity != 0:
        refuse(f"<option density={model.opt.density:g} viscosity={model.opt.viscosity:g}>: fluid forces would add "
               "torque; set both to 0")
    if not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT:
        pair = _possible_contact(model)
        if pair is not None:
            refuse(f"contacts are enabled and geoms '{pair[0]}' and '{pair[1]}' can collide: add "
                   "<flag contact=\"disable\"/> to <option>, or set their contype/conaffinity to 0")


def _gravity(model, joint: str, parts, notes: list, refuse, name) -> np.ndarray:
    """The gravity that exerts a torque: a top's (about its pivot), none on a free body (switched off in ``model``,
    said in ``notes``: a uniform field exerts no torque about the centre of mass)."""
    gravity = np.zeros(3)
    gravity_off = bool(model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY)  # <flag gravity="disable"/>
    if np.any(model.opt.gravity != 0) and joint == "free" and not gravity_off:
        notes.append(f"gravity {model.opt.gravity.tolist()} m/s^2 switched off: a uniform field exerts no torque "
                     "about the centre of mass")
        model.opt.gravity[:] = 0.0
    elif joint == "ball" and gravity_off:  # MuJoCo exerts none: the top turns torque free about its pivot
        if np.any(model.opt.gravity != 0):
            notes.append("gravity disabled by the model's <flag gravity=\"disable\"/>: the top turns torque free "
                         "about its pivot")
    elif joint == "ball":
        gravity = model.opt.gravity.copy()
        if not math.hypot(*gravity) <= MAX_GRAVITY:
            refuse(f"<option gravity=\"{' '.join(f'{g:g}' for g in gravity)}\">: |g| = {math.hypot(*gravity):.3g} "
                   f"m/s^2, beyond the {MAX_GRAVITY:.0e} m/s^2 (a thousand g) a top may turn in")
        compensated = [b for b in parts if model.body_gravcomp[b] != 0]
        if compensated:  # MuJoCo pushes up by gravcomp x m g at the part's centre: part of gravity's torque gone
            b = compensated[0]
            refuse(f"body '{name(mujoco.mjtObj.mjOBJ_BODY, b)}' has gravcomp=\"{model.body_gravcomp[b]:g}\": MuJoCo "
                   "would cancel that share of its weight, and of gravity's torque about the pivot, which xcheck's "
                   "top does not model; remove gravcomp (or switch gravity off with <flag gravity=\"disable\"/>)")
    return gravity


def _mass_properties(model, body_id: int, body_name: str, parts, wheels, notes: list):
    """``(mass, com, inertia, moments, iquat, wheels)`` of the rigid body: MuJoCo's own, as compiled, for one body;
    for parts welded together or a gyrostat, the composite (a gyrostat's less each wheel's axial moment: the wheels'
    momentum is a torque of the model's own, ``WheelsTorque``), with its notes. A wheel's pulse is left out where
    the model disables actuation (MuJoCo applies no motor's force)."""
    if len(parts) == 1 and not wheels:
        mass, moments, iquat = model.body_mass[body_id], model.body_inertia[body_id].copy(), model.body_iquat[body_id]
        com = model.body_ipos[body_id].copy()
        R = rot.quat_to_dcm(iquat)
        return mass, com, R @ np.diag(moments) @ R.T, moments, iquat, wheels
    mass, com, inertia = composite_inertia(model, body_id, wheels=[w.body for w in wheels])
    for w in wheels:
        inertia = inertia - w.moment * np.outer(w.axis, w.axis)
    moments, axes = np.linalg.eigh(inertia)  # the principal moments and axes in the body frame (sorted)
    if np.linalg.det(axes) < 0:
        axes[:, 2] *= -1
    iquat = rot.dcm_to_quat(axes)
    if len(parts) > 1:
        notes.append(f"{len(parts)} bodies without joints welded into one rigid body: mass {mass:g} kg, centre "
                     f"of mass {np.round(com, 9).tolist()} m in the frame of '{body_name}'")
    if wheels:
        notes.append(f"a gyrostat: {len(wheels)} axisymmetric wheel(s) ({', '.join(w.name for w in wheels)}); "
                     "the inertia is the whole body's about its centre of mass less each wheel's axial moment, "
                     "the wheels' momentum a torque of the model's own")
    if model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_ACTUATION and any(w.pulse for w in wheels):
        notes.append("actuation disabled by the model's <flag actuation=\"disable\"/>: MuJoCo applies no "
                     "motor's force, so the pulses of "
                     f"{', '.join(repr(w.name) for w in wheels if w.pulse)} are left out: the wheels turn freely")
        wheels = [replace(w, pulse=None, actuator=-1) for w in wheels]
    notes += [f"wheel '{w.name}' has a motor but no <numeric name=\"{PULSE_NUMERIC}ACTUATOR\"> commands it: the "
              "motor exerts nothing, and the wheel turns freely" for w in wheels if w.actuator >= 0 and w.pulse is None]
    return mass, com, inertia, moments, iquat, wheels


def _dipole(model, refuse) -> np.ndarray:
    """The permanent dipole [A m^2, body components] of ``<numeric name="xcheck_dipole">``, zero without one."""
    nid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_NUMERIC, DIPOLE_NUMERIC)
    if nid < 0:
        return np.zeros(3)
    size = int(model.numeric_size[nid])
    if size != 3:
        refuse(f"<numeric name=\"{DIPOLE_NUMERIC}\"> has {size} values; expected 3 (the dipole in A m^2, body "
               "components)")
    adr = int(model.numeric_adr[nid])
    return model.numeric_data[adr:adr + 3].copy()


def _multibody(model, roots, hinge) -> str | None:
    """Why a model is a multi-body one (a robot, a chain, several free bodies), or None: more than one moving body,
    and not one free or ball body whose other joints are hinges of bodies that hang from it (or from a part welded to
    it): a gyrostat's wheels, which :func:`_wheels` checks in detail."""
    moving = [b for b in range(1, model.nbody) if model.body_jntnum[b] > 0]
    if len(moving) < 2:
        return None
    kinds: dict = {}
    for j in range(model.njnt):
        kind = mujoco.mjtJoint(model.jnt_type[j]).name.removeprefix("mjJNT_").lower()
        kinds[kind] = kinds.get(kind, 0) + 1
    counted = ", ".join(f"{n} {k}" for k, n in kinds.items())
    why = (f"a multi-body model: {len(moving)} moving bodies and {model.njnt} joints ({counted}); xcheck checks one "
           "rigid body turning on a free or ball joint (with, at most, balanced wheels on hinges of it)")
    if len(roots) != 1:
        return why
    root = int(model.jnt_bodyid[roots[0]])
    for j in range(model.njnt):
        if j == roots[0]:
            continue
        b = int(model.jnt_bodyid[j])
        if int(model.jnt_type[j]) != hinge or model.body_weldid[int(model.body_parentid[b])] != root:
            return why
    return None


def body_poses(model, root: int, wheels=()) -> dict:
    """``{body: (position, rotation)}`` in ``root``'s frame of ``root``, the bodies below it without joints, and the
    ``wheels`` (bodies on a hinge) at their joint's zero: the chain of ``body_pos``/``body_quat``."""
    pose = {root: (np.zeros(3), np.eye(3))}
    for b in range(root + 1, model.nbody):  # MuJoCo numbers a parent before its children
        parent = int(model.body_parentid[b])
        if parent in pose and (not model.body_jntnum[b] or b in wheels):
            p, R = pose[parent]
            pose[b] = (p + R @ model.body_pos[b], R @ rot.quat_to_dcm(model.body_quat[b]))
    return pose


def composite_inertia(model, root: int, wheels=()) -> tuple[float, np.ndarray, np.ndarray]:
    """A body and the bodies below it in the tree that have no joints (and the ``wheels``, as if locked), as one
    rigid body (issue 27): its mass [kg], centre of mass [m] and inertia tensor about that centre [kg m^2], both in
    ``root``'s frame. Each part's pose in the root's frame is :func:`body_poses`', its own inertia is
    ``body_inertia`` about its centre (``body_ipos``) in its principal frame (``body_iquat``); the sum is the
    parallel-axis theorem, I_C = sum_b [R_b I_b R_b^T + m_b (|d_b|^2 E - d_b d_b^T)], d_b = c_b - c."""
    pose = body_poses(model, root, wheels)
    order = list(pose)
    masses = np.array([model.body_mass[b] for b in order])
    centres = np.array([pose[b][0] + pose[b][1] @ model.body_ipos[b] for b in order])
    mass = float(masses.sum())
    com = masses @ centres / mass
    inertia = np.zeros((3, 3))
    for b, m, c in zip(order, masses, centres):
        R = pose[b][1] @ rot.quat_to_dcm(model.body_iquat[b])
        d = c - com
        inertia += R @ np.diag(model.body_inertia[b]) @ R.T + m * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, com, 0.5 * (inertia + inertia.T)


def _wheels(model, root: int, joint: str, hinges, refuse, name) -> list:
    """The wheels of a gyrostat (issue 28): every hinge must turn a wheel, an axisymmetric body whose axis is the
    hinge's through its centre of mass, on the free body (or a part welded to it), with nothing below it; motors
    only on wheels (:data:`ALLOWED_ACTUATORS`). Refused by name otherwise."""
    J = mujoco.mjtObj.mjOBJ_JOINT
    if hinges and joint != "free":
        refuse(f"hinge joint '{name(J, hinges[0])}' on a top: wheels are modelled on a free body only")
    wheel_bodies = [int(model.jnt_bodyid[j]) for j in hinges]
    pose = body_poses(model, root, wheel_bodies)
    found = []
    for j, b in zip(hinges, wheel_bodies):
        jname, bname = name(J, j), name(mujoco.mjtObj.mjOBJ_BODY, b)
        where = f"hinge joint '{jname}' (body '{bname}'; a hinge is a wheel's here)"
        parent = int(model.body_parentid[b])
        if model.body_weldid[parent] != root or b not in pose:
            refuse(f"{where}: a hinge must turn a wheel on the free body itself (or on a part welded to it); "
                   "this one is elsewhere in the tree")
        if model.body_jntnum[b] != 1:
            refuse(f"{where}: a wheel turns on one hinge; body '{bname}' has {model.body_jntnum[b]} joints")
        if any(int(model.body_parentid[c]) == b for c in range(b + 1, model.nbody)):
            refuse(f"{where}: a wheel has no bodies below it; put its parts' geoms and inertia in body '{bname}'")
        dof = int(model.jnt_dofadr[j])
        for what, values in (("damping", model.dof_damping), ("armature", model.dof_armature),
                             ("frictionloss", model.dof_frictionloss)):
            if values[dof] != 0:
                refuse(f"{where} has {what} {values[dof]:g}: a wheel's axle is frictionless here (its motor is its only "
                       "torque); set it to 0")
        if model.jnt_stiffness[j] != 0 or model.jnt_limited[j]:
            refuse(f"{where} has {'stiffness' if model.jnt_stiffness[j] else 'a range'}: a wheel turns freely; remove it")
        axis = np.asarray(model.jnt_axis[j], dtype=float)
        axis = axis / np.linalg.norm(axis)
        d = model.body_ipos[b] - model.jnt_pos[j]
        off = np.linalg.norm(d - (d @ axis) * axis)
        if off > 1e-9 * (1.0 + np.linalg.norm(d)):
            refuse(f"{where}: its axis misses the wheel's centre of mass by {off:.3g} m; a wheel's hinge passes "
                   "through its centre of mass (a balanced wheel), or it would shake the body")
        R = rot.quat_to_dcm(model.body_iquat[b])
        Iw = R @ np.diag(model.body_inertia[b]) @ R.T
        Js = float(axis @ Iw @ axis)
        Jt = 0.5 * (np.trace(Iw) - Js)
        asym = np.linalg.norm(Iw - Jt * np.eye(3) - (Js - Jt) * np.outer(axis, axis))
        if asym > 1e-9 * np.linalg.norm(Iw):
            refuse(f"{where}: the wheel is not axisymmetric about its hinge (its inertia {np.round(Iw, 12).tolist()} "
                   "kg m^2 in its frame has no two equal moments about that axis); xcheck models balanced, "
                   "axisymmetric wheels")
        speed = float(model.key_qvel[0][dof]) if model.nkey else 0.0
        if not abs(speed) <= MAX_RATE:
            refuse(f"{where}: its speed in the first keyframe, '{name(mujoco.mjtObj.mjOBJ_KEY, 0)}', is {speed:g} "
                   f"rad/s: expected a finite speed of at most {MAX_RATE:.0e} rad/s")
        found.append(Wheel(name=jname, axis=tuple((pose[b][1] @ axis).tolist()), moment=Js, dof=dof,
                           qpos=int(model.jnt_qposadr[j]), body=b, speed=speed))
    by_joint = {j: k for k, j in enumerate(hinges)}
    for i in range(model.nu):
        aname = name(mujoco.mjtObj.mjOBJ_ACTUATOR, i)
        target = int(model.actuator_trnid[i, 0])
        plain = (int(model.actuator_trntype[i]) == int(mujoco.mjtTrn.mjTRN_JOINT) and target in by_joint
                 and int(model.actuator_dyntype[i]) == int(mujoco.mjtDyn.mjDYN_NONE)
                 and int(model.actuator_gaintype[i]) == int(mujoco.mjtGain.mjGAIN_FIXED)
                 and int(model.actuator_biastype[i]) == int(mujoco.mjtBias.mjBIAS_NONE))
        if not plain:
            refuse(f"actuator '{aname}': xcheck applies its own torques; allowed are only {ALLOWED_ACTUATORS}. A "
                   "velocity or position servo's result depends on its gains: not modelled")
        k = by_joint[target]
        if found[k].actuator >= 0:
            refuse(f"actuator '{aname}': wheel '{found[k].name}' has a motor already")
        gain = float(model.actuator_gear[i, 0] * model.actuator_gainprm[i, 0])
        if gain == 0:
            refuse(f"actuator '{aname}': its gear times gain is 0: it exerts nothing")
        found[k] = replace(found[k], actuator=i, gain=gain)
    actuators = {name(mujoco.mjtObj.mjOBJ_ACTUATOR, f.actuator): k for k, f in enumerate(found)
                 if f.actuator >= 0}
    for n in range(model.nnumeric):
        nname = name(mujoco.mjtObj.mjOBJ_NUMERIC, n)
        if not nname.startswith(PULSE_NUMERIC):
            continue
        aname = nname[len(PULSE_NUMERIC):]
        if aname not in actuators:
            refuse(f"<numeric name=\"{nname}\">: no motor named '{aname}' on a wheel (motors: "
                   f"{', '.join(actuators) or 'none'})")
        adr, size = int(model.numeric_adr[n]), int(model.numeric_size[n])
        values = model.numeric_data[adr:adr + size]
        if size != 3 or not np.all(np.isfinite(values)) or not 0 <= values[1] < values[2]:
            refuse(f"<numeric name=\"{nname}\">: expected data=\"peak t0 t1\" (a torque pulse of peak [N m] over "
                   f"[t0, t1] s, 0 <= t0 < t1), got {values.tolist()}")
        k = actuators[aname]
        i = found[k].actuator
        peak = float(values[0])
        ctrl = peak / found[k].gain
        if not abs(ctrl) <= MUJOCO_MAX_CTRL:  # MuJoCo zeroes every control where one is beyond (mju_isBad)
            refuse(f"actuator '{aname}': its pulse of {peak:g} N m needs a control of {ctrl:.3g} (gear times gain "
                   f"{found[k].gain:.3g}), beyond the {MUJOCO_MAX_CTRL:.0e} MuJoCo takes (it would zero every control "
                   "and exert nothing): give the motor a gear near 1")
        hinge_j = hinges[k]
        for what, limited, lo_hi, value in (
                ("ctrlrange", model.actuator_ctrllimited[i], model.actuator_ctrlrange[i], ctrl),
                ("forcerange", model.actuator_forcelimited[i], model.actuator_forcerange[i],
                 peak / model.actuator_gear[i, 0]),  # the actuator's force; the wheel's torque is gear x force
                (f"joint '{found[k].name}' actuatorfrcrange", model.jnt_actfrclimited[hinge_j],
                 model.jnt_actfrcrange[hinge_j], peak)):
            if limited and not (lo_hi[0] <= min(0.0, value) and max(0.0, value) <= lo_hi[1]):
                refuse(f"actuator '{aname}': its pulse needs {value:g} within its {what} {lo_hi.tolist()} (MuJoCo "
                       "would clip it, which xcheck's pulse does not model)")
        found[k] = replace(found[k], pulse=(peak, float(values[1]), float(values[2])))
    return found


#: MuJoCo's bound on a control (``mjMAXVAL``): beyond it, ``mju_isBad`` zeroes every control of the step.
MUJOCO_MAX_CTRL = 1e10


def _check_finite(model, refuse, name) -> None:
    """Refuse a model whose numbers xcheck reads (gravity, the bodies' poses and inertia, the joints' axes and
    positions, the actuators' gears and gains, the custom numerics) hold a NaN or an inf, naming the element."""
    O = mujoco.mjtObj
    arrays = (("<option gravity>", model.opt.gravity[None], None), ("<body pos>", model.body_pos, O.mjOBJ_BODY),
              ("<body quat>", model.body_quat, O.mjOBJ_BODY), ("<inertial mass>", model.body_mass[:, None], O.mjOBJ_BODY),
              ("<inertial> moments", model.body_inertia, O.mjOBJ_BODY), ("<inertial pos>", model.body_ipos, O.mjOBJ_BODY),
              ("<inertial quat>", model.body_iquat, O.mjOBJ_BODY), ("<joint axis>", model.jnt_axis, O.mjOBJ_JOINT),
              ("<joint pos>", model.jnt_pos, O.mjOBJ_JOINT), ("gear", model.actuator_gear, O.mjOBJ_ACTUATOR),
              ("gain", model.actuator_gainprm[:, :1], O.mjOBJ_ACTUATOR))
    for what, values, obj in arrays:
        bad = np.flatnonzero(~np.all(np.isfinite(values), axis=1))
        if bad.size:
            i = int(bad[0])
            whose = "" if obj is None else f"{obj.name.removeprefix('mjOBJ_').lower()} '{name(obj, i)}': "
            refuse(f"{whose}{what} {values[i].tolist()} is not finite: give finite numbers")
    if not np.all(np.isfinite(model.numeric_data)):
        for n in range(model.nnumeric):
            adr, size = int(model.numeric_adr[n]), int(model.numeric_size[n])
            if not np.all(np.isfinite(model.numeric_data[adr:adr + size])):
                refuse(f"<numeric name=\"{name(O.mjOBJ_NUMERIC, n)}\"> data "
                       f"{model.numeric_data[adr:adr + size].tolist()} is not finite: give finite numbers")


def _possible_contact(model):
    """The names of a geom pair (from different rigid bodies) whose contype/conaffinity allow contact, or None.
    Linear in the geoms: within each rigid body (a weld group) the contype and conaffinity bits are OR-ed, and two
    groups can touch exactly when a bit of one's contype is in the other's conaffinity (10 000 geoms scanned in
    pairs took 13 s in every process that loaded the model)."""
    if model.npair:
        return ("<contact><pair>", "explicitly listed")
    if not model.ngeom:
        return None
    weld = model.body_weldid[model.geom_bodyid]
    ct, ca = model.geom_contype.astype(np.int64), model.geom_conaffinity.astype(np.int64)
    groups = np.unique(weld)
    CT = np.array([np.bitwise_or.reduce(ct[weld == w]) for w in groups])
    CA = np.array([np.bitwise_or.reduce(ca[weld == w]) for w in groups])
    touch = ((CT[:, None] & CA[None, :]) | (CT[None, :] & CA[:, None])) != 0
    np.fill_diagonal(touch, False)
    if not touch.any():
        return None
    a, b = (groups[k] for k in np.argwhere(touch)[0])
    ga, gb = np.flatnonzero(weld == a), np.flatnonzero(weld == b)  # the pair itself, for the message
    hit = ((ct[ga][:, None] & ca[gb][None, :]) | (ct[gb][None, :] & ca[ga][:, None])) != 0
    g1, g2 = (int(x) for x in np.argwhere(hit)[0])
    return tuple(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, int(g)) or f"#{int(g)}" for g in (ga[g1], gb[g2]))
