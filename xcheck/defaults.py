"""Study defaults derived from the body (issue 36): the steps, the quick steps, the duration of a model alone and the
checks' limits, for a scenario that leaves them out — instead of one ladder for a body turning at 0.01 rad/s and one
turning at 100 rad/s.

:func:`derive` measures the motion it is given, cheaply and without any engine:

* the **coarsest step** turns the body by at most :data:`TURN_PER_STEP` rad at its fastest rate (the compiled
  DOP853 sampled over the duration), a power of two;
* the **finest step** is where every fourth-order method of ours reaches the round-off floor: each is run once
  (compiled) at a coarse step against DOP853, and the worst error extrapolated at order 4 down to :data:`FLOOR`; and
  at most the finest quick step, so that the first-order integrators' range is in the full study too (at most
  :data:`MAX_STEPS` steps a run, at least :data:`MIN_LADDER` steps in the ladder);
* the **quick steps** lie inside a first-order integrator's asymptotic range: a semi-implicit Euler pilot (MuJoCo's
  ``Euler``: the rate first, then the attitude with the new rate) over a window of at most :data:`PILOT_STEPS` steps
  (shorter, or at a smaller step, until its error is within 0.05 rad) gives the first-order error's constant,
  extrapolated linearly to the duration; the coarsest quick step is the largest power of two whose extrapolated
  error over the duration is at most :data:`QUICK_ERROR`, then four halvings;
* the **duration** of a model alone shows its own motion: three of its own periods (:func:`xcheck.reference.own_period`:
  a nutation, a tumble, a body cone), on the 1-2-5 series, between 1 s and 1000 s, and at most :data:`MAX_TURN` rad
  turned; one period where the quick steps would not fit in :data:`MAX_STEPS` steps over three;
* the **limits** are consistent with the floor the finest step can reach: ``final_error``, ``agreement`` and
  ``invariant_tolerance`` are 1e-9 or 100 times the floor predicted there (round-off grows with the steps and the
  angle turned), whichever is larger.

Each value comes with the sentence that says how it was derived (``why``): ``xcheck init`` writes them as comments,
the report states them among the assumptions."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import rotations as rot

__all__ = ["StudyDefaults", "derive", "seed_defaults", "SEED_STEPS", "SEED_QUICK_STEPS", "TURN_PER_STEP", "FLOOR",
           "QUICK_ERROR", "MAX_STEPS", "with_your_step"]

#: Seed 004 §3.3: 1/2, 1/4, ..., 1/4096 s (what a study takes where nothing is derived: the bundled scenarios write it)
SEED_STEPS = tuple(2.0**-k for k in range(1, 13))
#: ``--quick``: five steps, 1/64 ... 1/1024 s.
SEED_QUICK_STEPS = tuple(2.0**-k for k in range(6, 11))

#: The coarsest step turns the body by at most this [rad] at its fastest rate.
TURN_PER_STEP = 0.5
#: The fourth-order methods' round-off floor the finest step reaches [rad].
FLOOR = 1e-12
#: The coarsest quick step keeps a first-order integrator's error over the duration within this [rad]: well inside
#: the small-error regime (a T-handle tumbling at 20 rad/s: MuJoCo's implicit integrator's local order is 0.91 there,
#: 0.68 at 1e-2 rad).
QUICK_ERROR = 3e-3
#: At most this many steps in a run of the ladder (the finest: MuJoCo's step costs ~4 us) ...
MAX_STEPS = 2**16
#: ... and at least this many steps in the full ladder, at most MAX_LADDER (seed 004's study has 12).
MIN_LADDER, MAX_LADDER = 6, 14
#: The first-order pilot's steps (a Python loop: ~15 us a step).
PILOT_STEPS = 2048
#: A model alone's duration turns the body by at most this [rad] at its initial rate (three of its own periods,
#: else).
MAX_TURN = 3000.0
#: Beyond this turn [rad] over the duration, nothing is derived (:func:`derive` refuses: the seed's defaults stay).
MAX_DERIVE_TURN = 1e5
#: The thinnest body a study is derived for: its smallest principal moment at least this fraction of its largest
#: (issue 58). The rate about a thin axis changes by ``(J2 - J3) w2 w3 / J1``, which double precision rounds by
#: ``eps |w| |J w| / J1``; below 1e-11 that rounding is 2e-5 of the change, and the pilots' references (DOP853 at rtol
#: 1e-12, which widens its tolerance to that rounding: :data:`xcheck.integrators.dop853.NOISE_FACTOR`) took over a
#: million steps a second of motion. Measured on random rods, turned and not: of 80 from 1e-11 to 1e-3, 79 were
#: derived in at most 1.2 s and one (3e-10, over 200 s) was refused, its pilot's reference over its budget; three of
#: four below 1.7e-12 ran out of it. A thinner body is refused, saying so, and so is one whose pilots run out.
MIN_MOMENT_RATIO = 1e-11


@dataclass
class StudyDefaults:
    """What :func:`derive` found: ``steps`` (coarse to fine) and ``quick_steps`` [s], ``duration`` [s] (the one given,
    or derived), the checks' limits ``final_error`` (also ``agreement``) [rad] and ``invariant_tolerance``, and ``why``:
    key -> how it was derived, in words."""

    steps: tuple
    quick_steps: tuple
    duration: float
    final_error: float
    invariant_tolerance: float
    why: dict = field(default_factory=dict)


def _power_of_two_below(x: float) -> float:
    return 2.0 ** math.floor(math.log2(x))


def _nice_up(x: float) -> float:
    """``x`` rounded up on the 1-2-5 series."""
    k = math.floor(math.log10(x))
    for m in (1, 2, 5, 10):
        if m * 10.0**k >= x * (1 - 1e-12):
            return m * 10.0**k
    return 10.0 ** (k + 1)


def _ladder(top: float, bottom: float) -> tuple:
    n = max(1, int(round(math.log2(top / bottom))) + 1)
    return tuple(top / 2**k for k in range(n))


def derive(inertia, q0, omega0, duration: float | None, torque=None, your_step: float | None = None,
           your_step_why: str = "") -> StudyDefaults:
    """The defaults of a study of this motion (see the module docstring). ``duration`` None: a model alone's, derived
    too. ``inertia`` (3, 3) [kg m^2], ``q0`` [w, x, y, z] body -> world, ``omega0`` [rad/s] body frame, ``torque`` a
    :class:`~xcheck.fields.TorqueModel` or None. Where nothing can be derived (a motion of more than
    :data:`MAX_DERIVE_TURN` rad), the seed's ladder (:func:`seed_defaults`), saying why; a body thinner than
    :data:`MIN_MOMENT_RATIO`, or whose pilots' references run out of their budget, is refused (UserError).
    ``your_step`` [s]: the user's own step (an MJCF's ``<option timestep>``; ``your_step_why`` says where it comes
    from), made one of the steps and the quick steps and bracketed by them (:func:`with_your_step`)."""
    I = np.asarray(inertia, dtype=float)
    q0, omega0 = np.asarray(q0, dtype=float), np.asarray(omega0, dtype=float)
    from .integrators.dop853 import DOP853Failure

    moments = np.linalg.eigvalsh(I)
    if not moments[0] >= MIN_MOMENT_RATIO * moments[-1]:
        raise _no_study(moments, f"its smallest principal moment is {moments[0] / moments[-1]:.2g} of its largest, "
                                 f"below the {MIN_MOMENT_RATIO:g} a study is derived for")
    try:
        d = _derive(I, q0, omega0, duration, torque, your_step)
    except DOP853Failure as exc:  # a pilot's reference over its budget: no defaults, and no bug of ours
        raise _no_study(moments, f"its pilots' reference could not be computed ({exc})") from None
    if your_step is not None:
        for key in ("steps", "quick_steps"):
            ladder, said = with_your_step(getattr(d, key), float(your_step), d.duration, your_step_why)
            setattr(d, key, ladder)
            d.why[key] += said
    return d


def with_your_step(ladder, step: float, duration: float, why: str = "") -> tuple[tuple, str]:
    """``ladder`` (coarse to fine) with the user's own ``step`` [s] in it (issue 59), and the words that say so:
    a step of the ladder within 1e-9 of it becomes it exactly (nothing said); else it is added, with one step beyond it where the
    ladder does not reach past it (twice it, if a run of the ``duration`` still takes two steps; half of it, if a
    run still takes at most :data:`MAX_STEPS` steps), so that the study brackets it. The ladder's other steps stay
    (an order is fitted on them: :func:`xcheck.metrics.ladder_steps`). A step longer than ``duration`` is left
    out, saying so."""
    ladder = tuple(float(s) for s in ladder)
    named = f"your step {_label(step)} s" + (f" ({why})" if why else "")
    if step > duration:
        return ladder, f"; {named} is longer than the duration ({duration:g} s): not studied"
    from .trajectory import same_step

    if any(same_step(s, step) for s in ladder):
        return tuple(step if same_step(s, step) else s for s in ladder), ""  # the answer line names it
    added = [step]
    if step > ladder[0] and 2 * step <= duration / 2:
        added.append(2 * step)
    if step < ladder[-1] and duration / (step / 2) <= MAX_STEPS:
        added.append(step / 2)
    out = tuple(sorted(set(ladder) | set(added), reverse=True))
    beyond = [s for s in added if s != step]
    return out, f"; and {named}" + (f", with {_label(beyond[0])} s beyond it" if beyond else "")


def _no_study(moments, why: str):
    """The refusal of a body whose study cannot be derived (:data:`MIN_MOMENT_RATIO`)."""
    from .base.errors import UserError

    return UserError(f"inertia: no study can be derived for this body (principal moments {moments[0]:.3g}, "
                     f"{moments[1]:.3g}, {moments[2]:.3g} kg m^2): {why}; double precision rounds the rate about a thin "
                     "axis by eps |w| |J w| / J_min, which no reference resolves within its budget. Give the scenario "
                     "its own duration, steps and a 'dop853' or 'exact' reference, or a body at least "
                     f"{MIN_MOMENT_RATIO:g} as thick")


def _derive(I, q0, omega0, duration, torque, your_step=None) -> StudyDefaults:
    """:func:`derive` of a body thick enough."""
    from .integrators.dop853 import dop853_at
    from .reference import own_period

    why = {}
    given = duration is not None
    candidates = _Candidates([float(duration)]) if given else _durations(own_period(I, q0, omega0, torque), omega0)
    span = candidates[0]
    turned = float(np.linalg.norm(omega0)) * span
    if turned > MAX_DERIVE_TURN:
        return seed_defaults(span, f"the body turns {turned:.3g} rad over {span:g} s: too fast to derive steps from "
                                   f"(at most {MAX_DERIVE_TURN:g} rad)")
    try:
        _, w = dop853_at(I, q0, omega0, span, np.linspace(0.0, span, 65), torque=torque, rtol=1e-10, atol=1e-12,
                         max_steps=200_000)
    except RuntimeError as exc:
        return seed_defaults(span, f"its motion could not be sampled to derive steps from ({exc})")
    fastest = float(np.max(np.linalg.norm(w, axis=1)))
    if fastest == 0.0:  # at rest: nothing to resolve (the study says it is vacuous)
        duration = candidates[-1]
        top = _power_of_two_below(duration / 4)
        steps = _ladder(top, top / 2 ** (MIN_LADDER - 1))
        return StudyDefaults(steps, steps[-5:], duration, 1e-9, 1e-9,
                             {**({} if given else {"duration": f"{duration:g} s: the body is at rest"}),
                              "steps": f"{_label(steps[0])} … {_label(steps[-1])} s: the body is at rest (any steps)",
                              "quick_steps": f"{_label(steps[-5])} … {_label(steps[-1])} s: the body is at rest",
                              "final_error": "1e-09 rad"})

    # a first-order pilot (semi-implicit Euler, MuJoCo's) over a window in its small-error regime: its error per
    # second of duration and per second of step (the error grows about linearly with time: a phase error)
    pilot = _power_of_two_below(TURN_PER_STEP / fastest) / 8
    window = min(span, PILOT_STEPS * pilot)
    for _ in range(8):  # errors saturate at pi: a shorter window, else a smaller step
        error1 = _euler_pilot(I, q0, omega0, window, pilot, torque)
        if error1 <= 0.05:
            break
        if window / 4 >= 64 * pilot:
            window /= 4
        else:
            pilot /= 2
            window = min(window, PILOT_STEPS * pilot)
    rate1 = error1 / (window * pilot)

    def quick_top(T):  # the coarsest quick step whose first-order error over T stays within QUICK_ERROR
        return _power_of_two_below(QUICK_ERROR / (rate1 * T)) if rate1 > 0 else np.inf

    if not given:  # the longest candidate whose quick ladder fits in MAX_STEPS steps a run, else the shortest
        fits = [T for T in candidates if 16 * T / min(quick_top(T), T / 4) <= MAX_STEPS]
        duration = fits[0] if fits else candidates[-1]
        why["duration"] = f"{duration:g} s: {candidates.text}" + (
            "" if duration == candidates[0] else
            f"; {candidates[0]:g} s shortened so that a first-order integrator's quick steps fit in {MAX_STEPS} steps "
            "a run" if fits else f"; one period only: a first-order integrator's quick steps need more than {MAX_STEPS} "
            "steps a run over three (and over one: its finest quick step is the finest within them)")
    duration = float(duration)
    top = min(_power_of_two_below(TURN_PER_STEP / fastest), _power_of_two_below(duration / 4))
    smallest = 2.0 ** math.ceil(math.log2(duration / MAX_STEPS))  # the finest step within MAX_STEPS a run

    # the quick steps: inside the first-order pilot's small-error regime over the duration
    qt = max(min(quick_top(duration), top), 16 * smallest)
    quick = _ladder(qt, qt / 16)

    # the finest step: our fourth-order methods once each (in their small-error regime), the worst extrapolated at
    # order 4 to the floor; and at least the finest quick step (the first-order integrators' range)
    probe = top
    for _ in range(4):
        error4, worst = _fourth_order_pilot(I, q0, omega0, duration, probe, torque)
        if error4 < 1e-2 or probe / 4 < smallest:
            break
        probe /= 4
    finest = probe * (FLOOR / error4) ** 0.25 if 0 < error4 < np.inf else probe
    finest = max(_power_of_two_below(min(finest, top, quick[-1])), smallest)
    if round(math.log2(top / finest)) + 1 < MIN_LADDER:  # a ladder long enough for an order, beyond the cap if need be
        finest = top / 2 ** (MIN_LADDER - 1)
    steps = _ladder(top, finest)[-MAX_LADDER:]
    why["steps"] = (f"{_label(steps[0])} … {_label(steps[-1])} s: the coarsest turns the body by at most "
                    f"{TURN_PER_STEP:g} rad at its fastest rate ({fastest:.3g} rad/s); the finest is where our "
                    f"fourth-order methods reach {FLOOR:g} rad (the worst, {worst}, was {error4:.2g} rad at "
                    f"{_label(probe)} s, extrapolated at order 4), and at most the finest quick step"
                    + (f", or the finest within {MAX_STEPS} steps a run" if steps[-1] == smallest else ""))
    why["quick_steps"] = (f"{_label(quick[0])} … {_label(quick[-1])} s: a first-order integrator's error over the "
                          f"duration stays within {QUICK_ERROR:g} rad from the coarsest (a semi-implicit Euler pilot, "
                          f"MuJoCo's, {error1:.2g} rad over {window:.3g} s at {_label(pilot)} s, extrapolated linearly)"
                          + (f"; the finest within {MAX_STEPS} steps a run" if quick[-1] == smallest else ""))

    # the limits, from the floor the finest step can reach (round-off grows with the steps and the turn)
    n = duration / min(steps[-1], your_step / 2 if your_step and your_step < steps[-1] else steps[-1])  # yours too
    floor = max(FLOOR, np.finfo(float).eps * fastest * duration * math.sqrt(n))
    limit = max(1e-9, _nice_up(100 * floor))
    why["final_error"] = (f"{limit:g} rad: 1e-9, or 100 times the round-off floor at the finest step "
                          f"({floor:.2g} rad predicted: eps x the turn x sqrt(steps)), whichever is larger")
    return StudyDefaults(steps, quick, duration, limit, limit, why)


def seed_defaults(duration: float, why: str) -> StudyDefaults:
    """Seed 004's ladder (and its quick one), the steps longer than ``duration`` dropped, where nothing is derived
    (``why``, said with each value)."""
    steps = tuple(v for v in SEED_STEPS if v <= duration) or (duration,)
    quick = tuple(v for v in SEED_QUICK_STEPS if v <= duration) or (duration,)
    said = f"seed 004's, not derived from the body: {why}"
    return StudyDefaults(steps, quick, duration, 1e-9, 1e-9, {"duration": f"{duration:g} s ({said})",
                                                              "steps": f"{_label(steps[0])} … {_label(steps[-1])} s ({said})",
                                                              "quick_steps": f"{_label(quick[0])} … {_label(quick[-1])} s ({said})",
                                                              "final_error": "1e-09 rad"})


class _Candidates(list):
    """A model alone's durations to choose from, longest first, and how they came (``text``)."""

    text = ""


def _durations(period, omega0) -> _Candidates:
    """Three of the body's own periods, else one (each on the 1-2-5 series, between 1 s and 1000 s, turning at most
    :data:`MAX_TURN` rad); 10 s where no closed form knows its period."""
    out = _Candidates()
    if period is None or not np.isfinite(period):
        out.append(10.0)
        out.text = "no closed form knows this motion's own period"
        return out
    rate = float(np.linalg.norm(omega0))
    for n in (3, 1):
        T = min(max(_nice_up(n * period), 1.0), 1000.0)
        if rate * T > MAX_TURN and T > 1.0:
            T = max(1.0, _power_of_two_below(MAX_TURN / rate))
        if T not in out:
            out.append(T)
    out.text = (f"three of its own periods ({period:.3g} s: a nutation, a tumble or a body cone), on the 1-2-5 series"
                f", at most {MAX_TURN:g} rad turned")
    return out


def _label(dt: float) -> str:
    from .trajectory import step_label

    return step_label(dt)


#: The fourth-order methods of ours whose worst error sets the finest step (euler-rk4 aside: its singularities).
PILOT_METHODS = ("lie-rkmk4", "formulation-1", "formulation-2", "lie-cf4", "dcm-rk4", "gibbs-rk4", "rotvec-rk4",
                 "mrp-rk4")


def _fourth_order_pilot(I, q0, omega0, duration: float, dt: float, torque) -> tuple[float, str]:
    """The largest attitude error [rad] over ``duration`` at ``dt`` among :data:`PILOT_METHODS` (compiled: a few
    milliseconds), against DOP853, and which method had it."""
    from .integrators import integrate
    from .integrators.dop853 import dop853_at

    worst, name, q_ref = -1.0, "", None
    for method in PILOT_METHODS:
        traj = integrate(method, I, q0, omega0, dt=dt, duration=duration, torque=torque)
        if q_ref is None or len(q_ref) != len(traj.t):
            q_ref, _ = dop853_at(I, q0, omega0, duration, traj.t, torque=torque, rtol=2.5e-14, atol=2.5e-16)
        error = float(np.max(rot.attitude_error(traj.q, q_ref[:len(traj.t)]))) if traj.ok else np.inf
        if error > worst:
            worst, name = error, method
    return worst, name


def _euler_pilot(I, q0, omega0, duration: float, dt: float, torque) -> float:
    """The largest attitude error [rad] over ``duration`` of a semi-implicit Euler run at ``dt`` (MuJoCo's ``Euler``
    on a rotating body: the body rate first, ``w += dt I^-1 (tau - w x I w)``, then the attitude with the new rate,
    ``q = q exp(dt w)``) against DOP853 at its steps."""
    from .integrators.dop853 import dop853_at

    Iinv = np.linalg.inv(I)
    n = int(math.ceil(duration / dt - 1e-9))
    t = np.minimum(np.arange(n + 1) * dt, duration)
    q, w = np.array(q0, dtype=float), np.array(omega0, dtype=float)
    qs = np.empty((n + 1, 4))
    qs[0] = q
    for k in range(n):
        h = t[k + 1] - t[k]
        tau = np.zeros(3) if torque is None else np.asarray(torque(t[k], q, w), dtype=float)
        w = w + h * (Iinv @ (tau - np.cross(w, I @ w)))
        q = rot.quat_mul(q, rot.rotvec_to_quat(h * w))
        q = q / np.linalg.norm(q)
        qs[k + 1] = q
    q_ref, _ = dop853_at(I, q0, omega0, duration, t, torque=torque, rtol=1e-12, atol=1e-14)
    return float(np.max(rot.attitude_error(qs, q_ref)))


#: The checks' limits a scenario file may set in its [checks] table, and their defaults.
DEFAULT_CHECKS = {
    "order_tolerance": 0.3,  # allowed expected - observed order (a defect lowers the order)
    "order_excess": 1.0,  # allowed observed - expected order (pre-asymptotic: the next term dominates)
    "final_error": 1e-9,  # [rad] at the finest step, for methods of order >= 4
    "invariant_tolerance": 1e-9,  # relative energy / momentum drift at the finest step (torque free)
    "agreement": 1e-9,  # [rad] MuJoCo RK4 against our best method at the finest step
    "tolerance": 1e-6,  # [rad] the largest attitude error over the run a user accepts at their own step (issue 59)
    "expected_to_fail": [],  # methods whose checks are expected to fail (e.g. Euler angles at gimbal lock)
}


#: An adaptive method's study is a ladder of its own relative tolerances (its absolute tolerance keeps the
#: method's own proportion), not of its step: 1e-3 (scipy's default, seed 001's) to 1e-10 by decades ...
DEFAULT_TOLERANCES = tuple(10.0**-k for k in range(3, 11))
#: ... and three of them, every second decade, in a quick study ...
QUICK_TOLERANCES = (1e-3, 1e-5, 1e-7)
#: ... at one output step [s], where its trajectory is compared with the reference: the coarsest step of a
#: study (seed 004's). It is also the longest step an engine's adaptive integrator may take (Basilisk's integrate
#: within each task step) and the hold of its time-dependent inputs: a short one would leave its tolerances
#: nothing to control ...
ADAPTIVE_STEP = 0.5
#: ... unless the body turns more than this [rad] in it (:func:`default_adaptive_step`). Basilisk switches its MRPs
#: to the shadow set only between task steps (|σ| ≤ 1: a turn of at most π): a task step that turns the body by
#: more than π more can cross their singularity (|σ| → ∞ at a turn of 2π), where its adaptive integrators shrink
#: their steps and lose accuracy
#: (seed 001's gyroscope at 15.7 rad/s turns 7.9 rad in ½ s: RKF78 at rtol 1e-7 took 0.30 s for 1.1e-6 rad,
#: against 0.01 s for 1.6e-6 rad at ⅛ s). 2 rad keeps |σ| below tan((π + 2)/4) = 3.4 within any step.
ADAPTIVE_TURN = 2.0


def default_adaptive_step(omega0, duration: float) -> float:
    """An adaptive method's output step when the scenario names none: :data:`ADAPTIVE_STEP` (at most the
    duration), halved while the body's initial rate turns it by more than :data:`ADAPTIVE_TURN` in one step
    (down to 1/1024 s)."""
    step = min(ADAPTIVE_STEP, duration)
    rate = float(np.linalg.norm(omega0))
    while rate * step > ADAPTIVE_TURN and step > 2.0**-10:
        step /= 2
    return step
