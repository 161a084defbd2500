"""What each engine was given (issue 62): one sentence per engine on how it built the scenario's body — its joints,
where the wheels went, what xcheck switched off — so that a user need not read the engine's module to know what
was checked. The sentences restate the engine modules' own docstrings (which say why, with the numbers);
:func:`how_built` picks the one for the body (:func:`xcheck.engines.mechanism.mechanism_of`: free, a top, a
gyrostat) and adds its numbers."""

from __future__ import annotations

from .mechanism import WHEEL_MASS_FRACTION, Gyrostat, Top

__all__ = ["how_built", "body_built", "BUILT", "ENGINE_NAMES"]

_WHEELS = (f"each wheel {WHEEL_MASS_FRACTION:.0%} of the mass at the common centre of mass, its transverse moment "
           "half its axial one (only the axial moment turns the bus)")
#: How an engine is named in a sentence.
ENGINE_NAMES = {"xcheck": "xcheck (ours)", "mujoco": "MuJoCo", "basilisk": "Basilisk", "pybullet": "PyBullet",
                "dart": "DART", "drake": "Drake", "exudyn": "EXUDYN", "mjx": "MJX"}
#: Per engine and kind of body (free, top, gyrostat): what it was given.
BUILT = {
    "xcheck": {"free": "the body's inertia tensor about its centre of mass (from the MJCF), torques as xcheck's "
                       "models",
               "top": "the inertia about the pivot and the top's gravity as the torque c × m Rᵀg (Lagrange's top)",
               "gyrostat": "the body with its wheels' momentum h in body components (a gyrostat), motors' pulses "
                           "changing h"},
    "mujoco": {"free": "the MJCF as written, compiled by MuJoCo (its free joint and options; a torque applied at "
                       "every stage through the control callback)",
               "top": "the MJCF as written: the body on its ball joint under the model's gravity",
               "gyrostat": "the MJCF as written: the wheels on their hinges, its motors (where it has them) as "
                           "actuators"},
    "mjx": {"free": "the MJCF compiled by MuJoCo, run by MJX (JAX) in float32 and float64",
            "top": "the MJCF compiled by MuJoCo (the ball joint, the model's gravity), run by MJX",
            "gyrostat": "the MJCF compiled by MuJoCo (the wheels on their hinges), run by MJX"},
    "basilisk": {"free": "a Spacecraft hub with the body's inertia tensor (its mass plays no part), no gravity; a "
                         "torque through Basilisk's own modules (extForceTorque, MtbEffector, "
                         "GravityGradientEffector, by kind), read once a task step",
                 "top": "a free hub with the inertia about the pivot (the hub has no joint); the top's gravity "
                        "c × m Rᵀg through extForceTorque, set before each step and held over it",
                 "gyrostat": "a Spacecraft hub with the whole body's inertia and the wheels as its "
                             "ReactionWheelStateEffector (balanced: their mass left to the hub; their speeds "
                             "Basilisk states), motors' pulses as rwMotorCmdInMsg held over each step"},
    "pybullet": {"free": "one body, gravity off: a btMultiBody with a floating base (multibody, its default angular "
                         "damping 0.04 set to 0) or a btRigidBody (maximal, Bullet's implicit gyroscopic term); "
                         "Bullet's clamp of pi/4 a step kept (a run that needs more fails, saying so), its bound of "
                         "100 on each speed lifted",
                 "top": "a link on a JOINT_SPHERICAL at a fixed base under Bullet's gravity (the multibody path): "
                        "the joint's default servo motor off, its speed bound lifted",
                 "gyrostat": "the bus a floating base, each wheel a link on a JOINT_REVOLUTE (its default motor off, "
                             f"motors' pulses as TORQUE_CONTROL held over each step); {_WHEELS}"},
    "dart": {"free": "one BodyNode on a FreeJoint in a World without gravity, the inertia tensor products included; "
                     "the torque held over each step",
             "top": "a BodyNode on a BallJoint at the origin under the model's gravity, its inertia about the "
                    "centre of mass",
             "gyrostat": f"the bus on a FreeJoint, each wheel a child on a RevoluteJoint along its axis; {_WHEELS}"},
    "drake": {"free": "one free body in a continuous MultibodyPlant (time_step 0), gravity off, the inertia tensor "
                      "products included; its quaternion integrated as four numbers (normalised when read)",
              "top": "a body on a BallRpyJoint at the origin under the model's gravity",
              "gyrostat": "the bus a free body, each wheel a body on a RevoluteJoint along its axis (motors' pulses "
                          f"as applied generalized forces); {_WHEELS}"},
    "exudyn": {"free": "one NodeRigidBodyRotVecLG body (a rotation vector, Lie group updates), the inertia tensor "
                       "products included, no gravity; the torque a LoadTorqueVector evaluated at every stage",
               "top": "its implicit solvers only: the node at the pivot held by three CoordinateConstraints (a ball "
                      "joint), the inertia about the pivot, gravity a mass-proportional load",
               "gyrostat": "not run: its wheels would be bodies on revolute-joint constraints, which its explicit "
                           "solvers cannot solve"},
}


def how_built(engine: str, mechanism) -> str | None:
    """What ``engine`` was given for a body built as ``mechanism`` (a :class:`~xcheck.engines.mechanism.Top`, a
    :class:`~xcheck.engines.mechanism.Gyrostat`, or None: a free body); None for an engine not known here."""
    sentences = BUILT.get(engine)
    if sentences is None:
        return None
    return sentences["top" if isinstance(mechanism, Top) else "gyrostat" if isinstance(mechanism, Gyrostat) else
                     "free"]


def body_built(mechanism) -> str:
    """The body every engine was given, in words with its numbers: ``a free body``, ``a top: mass 2.02 kg, ...``,
    ``a gyrostat: 3 wheels``."""
    if isinstance(mechanism, Top):
        return (f"a top: mass {mechanism.mass:.6g} kg, centre of mass {_vec(mechanism.centre)} m from the pivot, "
                f"gravity {_vec(mechanism.gravity)} m/s^2")
    if isinstance(mechanism, Gyrostat):
        n = len(mechanism.wheels)
        return f"a gyrostat: a bus and {n} wheel{'s' if n != 1 else ''}"
    return "a free body"


def _vec(v) -> str:
    return "[" + ", ".join(f"{float(x):.6g}" for x in v) + "]"
