"""Every method of the cross-check, ours and the engines' (MuJoCo's; Basilisk's when it is installed), as a
runner with one signature: ``runner.run(context, dt) -> Trajectory``."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Callable

from .engines import WITHOUT_VARIABLE, available, findings, installed, left_out
from .engines.mechanism import joint_kinds, model_text
from .integrators import METHODS, integrate, integrate_batch
from .trajectory import Trajectory

__all__ = ["Runner", "RUNNERS", "RunContext", "BASILISK_METHODS", "unknown_method"]


@dataclass
class RunContext:
    """What a runner needs: the body (inertia from the MJCF), the MJCF path, the initial state, the
    duration, the torque model (or None) and the Euler sequence of Euler-angle methods. ``model_moments``:
    principal moments that replace the MJCF's in MuJoCo's model (``body_inertia``) when a sweep changes the
    inertia (``inertia`` is then the same body's tensor); None: the MJCF's own."""

    inertia: object
    model_path: str
    q0: object
    omega0: object
    duration: float
    torque: object = None
    sequence: str = "323"
    model_moments: tuple | None = None
    #: what an engine that simulates the MJCF applies: ``torque`` less the model's own (a top's gravity about its
    #: pivot, a gyrostat's wheels, which such an engine exerts itself); "same": ``torque``
    engine_torque: object = "same"
    #: a gyrostat's wheels' initial speeds relative to the body [rad/s] (None: the model's)
    wheel_speeds: tuple | None = None
    #: the torque the model exerts itself (a top's gravity, a gyrostat's wheels; part of ``torque``), or None
    own: object = None
    #: the MJCF's body (:class:`xcheck.models.MJCFBody`): what the engines that build their own model of a top or a
    #: gyrostat read its joint, centre of mass, gravity and wheels from (:func:`xcheck.engines.mechanism.mechanism_of`)
    body: object = None

    @property
    def applied(self):
        """The torque an engine simulating the MJCF applies (see :attr:`engine_torque`)."""
        return self.torque if isinstance(self.engine_torque, str) else self.engine_torque


@dataclass(frozen=True)
class Runner:
    """One method of the cross-check. ``engine`` is ``"xcheck"`` for ours, else the simulator's name;
    ``agreement``: the study checks this method against our best fourth-order method at the finest step (an
    engine's RK4); ``line_style``: how plots draw it (ours solid, engines dashed); ``run_batch(ctx, q0 (N, 4),
    omega0 (N, 3), dt)``: many initial states at once, for the methods that have a batch path (``xcheck bench``
    times it). An ``adaptive`` method controls its own steps: its ``run(ctx, dt, rtol=None)`` takes a relative
    tolerance (None: its defaults) and ``dt`` is its output step; a study runs it over a ladder of tolerances.
    ``demonstration``: why a method exists that nobody should use (the report never recommends it)."""

    name: str
    engine: str  # "xcheck" | "mujoco"
    expected_order: int | None
    summary: str
    run: Callable[[RunContext, float], Trajectory]
    agreement: bool = False
    line_style: str = "-"
    run_batch: Callable | None = None
    #: ``(torque table of a scenario, or None) -> (order, why)``: the order this method can reach with that
    #: torque when it is lower than ``expected_order`` (an engine that holds its input over a step); None: always
    #: ``expected_order``.
    order_with: Callable | None = None
    #: the method of ours that is the same scheme (an engine's RK4 on its own attitude coordinates): its
    #: trajectory partner in a study, and the report's explanation of the engine's error
    twin: str | None = None
    adaptive: bool = False
    demonstration: str | None = None
    #: ``dt -> note or None``: how the engine's clock takes a step (a note when it rounds it); ValueError, naming
    #: why, for a step it cannot take. None: any step, as given.
    clock: Callable[[float], str | None] | None = None
    #: its engine is opt-in (:attr:`xcheck.engines.Engine.opt_in`): the method runs only where it is asked for
    opt_in: bool = False
    #: ``() -> note or None``: a known finding that the method's failed order check names (an engine release's RK4
    #: of second order, :func:`xcheck.engines.findings.release_note`), read for the version installed; None: none
    finding: Callable[[], str | None] | None = None
    #: ``(model path) -> why or None``: why this method cannot represent a scenario's body (its engine has no model
    #: here of a top's joint or a gyrostat's wheels); such a study leaves it out and says why. None: any body.
    cannot: Callable[[object], str | None] | None = None
    #: known findings of the engine's that explain a failed check where they are at work: each ``(check,
    #: MethodResult, scenario) -> note or None`` (the note names the finding, its source and the numbers that show
    #: it here); such a check is ``known``, neither passed nor failed (:func:`xcheck.study.checks.explain_known`)
    known: tuple = ()

    def cannot_run(self, model) -> str | None:
        """Why this method cannot represent the body of the MJCF ``model``, or None."""
        return None if self.cannot is None else self.cannot(model)

    def run_at(self, ctx: RunContext, dt: float, rtol: float | None = None) -> Trajectory:
        """``run`` at the step ``dt`` and, for an adaptive method, the tolerance ``rtol`` (None: its defaults). What
        an engine other than ours and MuJoCo (whose warnings it collects itself) writes to the standard error is
        caught into the trajectory's ``extras["engine_said"]`` (:func:`xcheck.base.captured.engine_said`)."""
        if self.engine in ("xcheck", "mujoco"):
            return self.run(ctx, dt) if rtol is None else self.run(ctx, dt, rtol)
        from .base.captured import engine_said

        said = []
        with engine_said(said):
            traj = self.run(ctx, dt) if rtol is None else self.run(ctx, dt, rtol)
        if said:
            traj.extras["engine_said"] = said
        return traj

    def order_for(self, torque: dict | None, model=None) -> tuple[int | None, str | None]:
        """The order expected of this method with a scenario's torque (and its ``model``'s own inputs: a gyrostat's
        motor pulses), and why when it is not the method's own."""
        if self.order_with is None or self.expected_order is None:
            return self.expected_order, None
        order, why = self.order_with(torque, model)
        return (self.expected_order, None) if order is None or order >= self.expected_order else (order, why)


def _release_finding(package: str, engine: str):
    def finding():
        from .engines.findings import release_note
        from .base.packages import package_version

        return release_note(package_version(package), engine)
    return finding


def _ours(name):
    def run(ctx: RunContext, dt: float, rtol: float | None = None) -> Trajectory:
        return integrate(name, ctx.inertia, ctx.q0, ctx.omega0, dt=dt, duration=ctx.duration, torque=ctx.torque,
                         sequence=ctx.sequence, rtol=rtol)
    return run


def _ours_batch(name):
    def run_batch(ctx: RunContext, q0, omega0, dt: float):
        return integrate_batch(name, ctx.inertia, q0, omega0, dt=dt, duration=ctx.duration, torque=ctx.torque,
                               sequence=ctx.sequence)
    return run_batch


def _mujoco(integrator):
    def run(ctx: RunContext, dt: float) -> Trajectory:
        from .engines.mujoco import simulate

        return simulate(ctx.model_path, integrator=integrator, q0=ctx.q0, omega0=ctx.omega0, dt=dt,
                        duration=ctx.duration, torque=ctx.applied,
                        inertia_moments=ctx.model_moments, wheel_speeds=ctx.wheel_speeds)
    return run


def _basilisk(integrator):
    def run(ctx: RunContext, dt: float, rtol: float | None = None) -> Trajectory:
        from .engines.basilisk import simulate

        return simulate(ctx.inertia, integrator=integrator, q0=ctx.q0, omega0=ctx.omega0, dt=dt,
                        duration=ctx.duration, torque=ctx.torque, rtol=rtol)
    return run


def _basilisk_clock(dt: float) -> str | None:
    from .engines.basilisk import clock_step

    return clock_step(dt)[1]


#: Why a composition of Strang steps loses order on a torque that is not smooth in time.
BACKWARDS = ("Yoshida's triple jump takes its torque up to 0.35 h outside each step (every splitting beyond order 2 "
             "steps backwards in time: Sheng 1989, Suzuki 1991), across ")


def _composition_order(torque: dict | None, model=None):
    """``order_with`` of ``split-yoshida4``: 2 where a field is a table interpolated linearly in time (its pieces
    meet in kinks), 3 where a motor's sin^2 pulse starts and stops (its second derivative jumps there); measured on
    rax1-body-field and tumbler-three-wheels (2.00, 3.00)."""
    from .fields import FIELDS, BodyFieldTable
    from .torque_terms import torque_terms

    if any(term.get("kind") == "magnetic" and issubclass(FIELDS[term["field"]], BodyFieldTable)
           for term in torque_terms(torque)):
        return 2, BACKWARDS + "the kinks of the field table's linear pieces: order 2"
    if model is not None and _declares_pulses(model):
        return 3, BACKWARDS + "the ends of the motor's sin² pulse, where its second derivative jumps: order 3"
    return None, None


def _basilisk_input_order(torque: dict | None, model=None):
    """The order Basilisk's held inputs leave with a scenario's torque and its model's motor pulses, and why
    (:func:`xcheck.engines.basilisk.input_order`, which the run itself reports)."""
    from .engines.basilisk import MIDPOINT_NOTE, input_order
    from .fields import FIELDS
    from .torque_terms import torque_terms

    orders = [input_order(term.get("kind"), FIELDS[term["field"]] if term.get("kind") == "magnetic" else None)
              for term in torque_terms(torque)]
    if model is not None and _declares_pulses(model):
        orders.append(input_order("motor-pulse"))
    orders = [o for o in orders if o is not None]
    if not orders:
        return None, None
    order = min(orders)
    return order, (MIDPOINT_NOTE if order == 2 else "Basilisk takes the torque at each step's start and holds it "
                   "over the step: first order")


def _engine_cannot(module: str, *args):
    """``cannot`` of an engine that builds tops and gyrostats on its own joints: its module's ``cannot(*args,
    mechanism)`` of the body's kind (:func:`_kind_of`, read from the MJCF's text: no MuJoCo at planning)."""
    def cannot(model) -> str | None:
        import importlib

        kind = _kind_of(model)
        return None if kind is None else importlib.import_module(module).cannot(*args, kind)
    return cannot


def _kind_of(model):
    """The engine-built kind of an MJCF's body, from its joints (:func:`~xcheck.engines.mechanism.joint_kinds`): the class
    :class:`~xcheck.engines.mechanism.Top` for a ball joint, :class:`~xcheck.engines.mechanism.Gyrostat` for wheels'
    hinges, None for a free body."""
    from .engines.mechanism import Gyrostat, Top

    kinds = joint_kinds(model)
    return Top if "ball" in kinds else Gyrostat if kinds else None


def _declares_pulses(model) -> bool:
    """Whether an MJCF declares a motor's pulse (``<numeric name="xcheck_pulse:...">``, outside comments), read from its
    text (:func:`~xcheck.engines.mechanism.model_text`); the model's loading checks that each names a wheel's motor."""
    import re

    text = model_text(model)
    if text is None:
        return False
    return re.search(r"<numeric\s[^>]*name\s*=\s*[\"']xcheck_pulse:", text) is not None


#: Basilisk's methods: registered when its package (the extra ``basilisk``) is installed.
BASILISK_METHODS = {
    "basilisk-rk4": (4, "Basilisk's RK4 on its hub (MRP attitude, torque through its own effectors)"),
    "basilisk-rkf45": (None, "Basilisk's adaptive RKF45 inside each task step (defaults rtol 1e-4, atol 1e-8)"),
    "basilisk-rkf78": (None, "Basilisk's adaptive RKF78 inside each task step (defaults rtol 1e-4, atol 1e-8)"),
}

RUNNERS: dict[str, Runner] = {
    name: Runner(name, "xcheck", m.expected_order, m.summary, _ours(name),
                 run_batch=_ours_batch(name) if m.kernel is not None else None, adaptive=m.adaptive,
                 demonstration=m.demonstration, order_with=_composition_order if name == "split-yoshida4" else None)
    for name, m in METHODS.items()}
RUNNERS.update({
    f"mujoco-{i}": Runner(f"mujoco-{i}", "mujoco", order, summary, _mujoco(i), agreement=(i == "rk4"), line_style="--",
                          twin="lie-rkmk4" if i == "rk4" else None,
                          finding=_release_finding("mujoco", "MuJoCo") if i == "rk4" else None)
    for i, order, summary in [
        ("rk4", 4, "MuJoCo's RK4 (torque in the control callback at every stage)"),
        ("euler", 1, "MuJoCo's semi-implicit Euler"),
        ("implicit", 1, "MuJoCo's implicit-in-velocity Euler"),
        ("implicitfast", 1, "MuJoCo's implicitfast (no Coriolis derivatives)"),
    ]
})
if available("basilisk"):
    RUNNERS.update({name: Runner(name, "basilisk", order, summary, _basilisk(name.removeprefix("basilisk-")),
                                 agreement=(name == "basilisk-rk4"), line_style=":", order_with=_basilisk_input_order,
                                 twin="mrp-rk4" if name == "basilisk-rk4" else None, adaptive=order is None,
                                 clock=_basilisk_clock)
                    for name, (order, summary) in BASILISK_METHODS.items()})


def _mjx(integrator, x64):
    def run(ctx: RunContext, dt: float) -> Trajectory:
        from .engines.mjx import simulate

        return simulate(ctx.model_path, integrator=integrator, q0=ctx.q0, omega0=ctx.omega0, dt=dt,
                        duration=ctx.duration, torque=ctx.applied, x64=x64, inertia_moments=ctx.model_moments,
                        wheel_speeds=ctx.wheel_speeds)
    return run


def _held_input_order(torque: dict | None, model=None):
    """MJX holds an applied torque and a motor's command over each step (no control callback): first order."""
    if torque is None and not (model is not None and _declares_pulses(model)):
        return None, None
    return 1, "MJX takes the torque (and the motors' commands) at each step's start and holds it over the step: first order"


#: MJX's methods: registered when its package (the extra ``mjx``) is installed; opt-in (``xcheck report --with mjx``)
MJX_METHODS = {
    f"mjx-{i}{suffix}": (order, f"MJX's {what} ({precision}; opt-in: --with mjx)", i, suffix == "-x64")
    for i, order, what in (("rk4", 4, "RK4"), ("euler", 1, "semi-implicit Euler"), ("implicitfast", 1, "implicitfast"))
    for suffix, precision in (("", "float32, JAX's default"), ("-x64", "float64: jax_enable_x64"))}
if available("mjx"):
    RUNNERS.update({name: Runner(name, "mjx", order, summary, _mjx(integrator, x64), line_style="-.",
                                 order_with=_held_input_order, twin="lie-rkmk4" if integrator == "rk4" else None,
                                 opt_in=True, finding=_release_finding("mujoco-mjx", "MJX") if integrator == "rk4"
                                 else None)
                    for name, (order, summary, integrator, x64) in MJX_METHODS.items()})


def _bullet(path):
    def run(ctx: RunContext, dt: float) -> Trajectory:
        from .engines.bullet import simulate
        from .engines.mechanism import mechanism_of

        mechanism = mechanism_of(ctx)
        return simulate(ctx.inertia, path=path, q0=ctx.q0, omega0=ctx.omega0, dt=dt, duration=ctx.duration,
                        torque=ctx.torque if mechanism is None else ctx.applied, mechanism=mechanism)
    return run


#: PyBullet's methods (issue 40): Bullet's two paths for one body, registered when ``pybullet`` is installed (the
#: extra ``engines``). Both step semi-implicitly and hold the torque over the step: first order. A run whose steps
#: turn the body beyond Bullet's pi/4 is failed, saying so (:data:`xcheck.engines.bullet.MAX_TURN`).
BULLET_METHODS = {
    "pybullet-multibody": "Bullet's btMultiBody (PyBullet's createMultiBody; its default angular damping 0.04 set "
                          "to 0), semi-implicit Euler, the torque held over each step",
    "pybullet-maximal": "Bullet's btRigidBody (maximal coordinates, its implicit gyroscopic term), semi-implicit "
                        "Euler, the torque held over each step",
}
if available("pybullet"):
    RUNNERS.update({name: Runner(name, "pybullet", 1, summary, _bullet(name.removeprefix("pybullet-")),
                                 line_style="-.", cannot=_engine_cannot("xcheck.engines.bullet",
                                                                        name.removeprefix("pybullet-")))
                    for name, summary in BULLET_METHODS.items()})


def _dart(ctx: RunContext, dt: float) -> Trajectory:
    from .engines.dart import simulate
    from .engines.mechanism import mechanism_of

    mechanism = mechanism_of(ctx)
    return simulate(ctx.inertia, q0=ctx.q0, omega0=ctx.omega0, dt=dt, duration=ctx.duration,
                    torque=ctx.torque if mechanism is None else ctx.applied, mechanism=mechanism)


#: DART's method (issue 40): its World's own integrator, registered when ``dartpy`` is installed (the extra
#: ``engines``); the torque held over each step. Its truncated exponential map is a known finding.
DART_METHODS = {"dart-semi-implicit-euler": "DART's World on a FreeJoint: semi-implicit Euler, the torque held over "
                                            "each step"}
if available("dart"):
    RUNNERS.update({name: Runner(name, "dart", 1, summary, _dart, line_style="--",
                                 known=(findings.dart_truncated_exponential,))
                    for name, summary in DART_METHODS.items()})


def _integrator_of(module: str, integrator: str):
    """A runner's ``run`` for an engine module whose ``simulate`` takes the integrator by name (Drake's, EXUDYN's):
    the free body, its state and torque from the context."""
    def run(ctx: RunContext, dt: float) -> Trajectory:
        import importlib

        from .engines.mechanism import mechanism_of

        mechanism = mechanism_of(ctx)
        return importlib.import_module(module).simulate(ctx.inertia, integrator=integrator, q0=ctx.q0,
                                                        omega0=ctx.omega0, dt=dt, duration=ctx.duration,
                                                        torque=ctx.torque if mechanism is None else ctx.applied,
                                                        mechanism=mechanism)
    return run


#: Drake's methods (issue 40): the integrators of its Simulator in fixed-step mode on a continuous MultibodyPlant,
#: registered when ``drake`` is installed (the extra ``engines``); the torque at every stage. Their Euler methods'
#: known findings: the additive quaternion, explicit Euler's late first order.
DRAKE_METHODS = {
    "drake-explicit-euler": (1, "Drake's explicit Euler (Simulator, fixed step) on a continuous MultibodyPlant",
                             (findings.drake_additive_quaternion, findings.drake_explicit_euler_pre_asymptotic)),
    "drake-semi-explicit-euler": (1, "Drake's semi-explicit (symplectic) Euler on a continuous MultibodyPlant",
                                  (findings.drake_additive_quaternion,)),
    "drake-rk2": (2, "Drake's second-order Runge-Kutta on a continuous MultibodyPlant", ()),
    "drake-rk3": (3, "Drake's third-order Runge-Kutta on a continuous MultibodyPlant", ()),
}
if available("drake"):
    RUNNERS.update({name: Runner(name, "drake", order, summary,
                                 _integrator_of("xcheck.engines.drake", name.removeprefix("drake-")), line_style=":",
                                 known=known)
                    for name, (order, summary, known) in DRAKE_METHODS.items()})


#: EXUDYN's methods (issue 40): its solvers at a fixed step on a Lie group rigid-body node (NodeRigidBodyRotVecLG),
#: registered when ``exudyn`` is installed (the extra ``engines``); the torque at every stage.
EXUDYN_METHODS = {
    "exudyn-explicit-euler": (1, "EXUDYN's explicit Euler, Lie group update of the rotation vector"),
    "exudyn-explicit-midpoint": (2, "EXUDYN's explicit midpoint rule, Lie group update"),
    "exudyn-rk44": (4, "EXUDYN's classical Runge-Kutta (RK44), explicit Lie group integration"),
    "exudyn-rk67": (6, "EXUDYN's sixth-order Runge-Kutta (RK67), explicit Lie group integration"),
    "exudyn-generalized-alpha": (2, "EXUDYN's implicit generalized-alpha solver (Newton at every step)"),
    "exudyn-trapezoidal-index2": (2, "EXUDYN's implicit trapezoidal rule (index 2), Newton at every step"),
}
if available("exudyn"):
    RUNNERS.update({name: Runner(name, "exudyn", order, summary,
                                 _integrator_of("xcheck.engines.exu", name.removeprefix("exudyn-")), line_style="--",
                                 cannot=_engine_cannot("xcheck.engines.exu", name.removeprefix("exudyn-")),
                                 twin="lie-rkmk4" if name == "exudyn-rk44" else None)
                    for name, (order, summary) in EXUDYN_METHODS.items()})


def unknown_method(name: str) -> str:
    """The message for a method name that is not a runner: an engine's that is not installed says how to get it."""
    if name in BASILISK_METHODS:
        if left_out("basilisk") and installed("basilisk"):
            return (f"{name!r} is Basilisk's, which ${WITHOUT_VARIABLE} ({os.environ.get(WITHOUT_VARIABLE, '')!r}) "
                    "leaves out here")
        return (f"{name!r} is Basilisk's, which is not installed here: pip install 'xcheck[basilisk]' (the PyPI "
                "package bsk)")
    if name in DART_METHODS:
        return f"{name!r} is DART's, which is not installed here: pip install 'xcheck[engines]' (PyPI dartpy)"
    if name in DRAKE_METHODS:
        return f"{name!r} is Drake's, which is not installed here: pip install 'xcheck[engines]' (PyPI drake)"
    if name in BULLET_METHODS:
        return f"{name!r} is PyBullet's, which is not installed here: pip install 'xcheck[engines]' (PyPI pybullet)"
    if name in MJX_METHODS:
        return (f"{name!r} is MJX's, which is not installed here: pip install 'xcheck[mjx]' (the PyPI packages "
                "mujoco-mjx and jax)")
    return f"unknown method {name!r}; expected one of {', '.join(RUNNERS)}"
