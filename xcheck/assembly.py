"""Physics assembled once: a scenario (plain data: :class:`xcheck.scenario.Scenario`) and its MJCF body become the
torque on the body — the scenario's terms and the model's own (a top's gravity, a gyrostat's wheels) — and a
runner's :class:`~xcheck.runners.RunContext`. A scenario's model is checked here (it loads, its torque builds and is
finite, its reference exists) and the keys its file left out are derived from the body. The study, the sweeps, the
pytest plugin and the report take the body and torque from here; the scenario's reader imports nothing of it but
:func:`check_scenario_model`, when it is asked to check."""

from __future__ import annotations

import numpy as np

from .base.errors import ScenarioError
from .defaults import DEFAULT_CHECKS, derive
from .torque_terms import torque_terms

__all__ = ["context_of", "wheels_stiffness", "build_torque", "torque_parts", "check_scenario_model", "fill_derived", "MAX_DIPOLE"]


def context_of(scenario, body=None):
    """The :class:`~xcheck.runners.RunContext` of ``scenario`` on ``body`` (its MJCF's, loaded when not given): the
    inertia (the scenario's moments where a sweep changes them), the initial state, the torque on the body, and
    what an engine that simulates the MJCF applies itself (the scenario's torque; the model's own it exerts)."""
    from .runners import RunContext

    if body is None:
        from .models import load_body

        body = load_body(scenario.model)
    moments = scenario.inertia
    own, applied = torque_parts(scenario, body)
    return RunContext(inertia=body.inertia_for(moments), model_path=str(scenario.model), q0=scenario.q0,
                      omega0=scenario.omega0, duration=scenario.duration, torque=_sum(own, applied),
                      sequence=scenario.sequence, model_moments=None if moments is None else tuple(moments),
                      engine_torque="same" if own is None else applied, wheel_speeds=scenario.wheel_speeds,
                      own=own, body=body)


def _sum(own, applied):
    if own is not None and applied is not None:  # a magnetised top in a field: both, summed at every stage
        from .fields import SumTorque

        return SumTorque([own, applied])
    return own if own is not None else applied


#: The step [s] of the wheels-stiffness runs (lie-rkmk4: its error 1e-12 rad there), and their samples kept.
STIFFNESS_DT, STIFFNESS_SAMPLES = 1 / 512, 512


def wheels_stiffness(scenario, body=None) -> dict | None:
    """Issue 28: how a gyrostat's wheels stiffen its attitude. The angle [deg] by which the direction of the wheels'
    momentum (a body axis) turns away from where it started, in the world, with the wheels as the scenario has them
    and with them stopped (the same body as one rigid mass), under the scenario's torque: ``lie-rkmk4`` at
    :data:`STIFFNESS_DT` (its error 1e-12 rad, nothing next to the lines), at most :data:`STIFFNESS_SAMPLES` times
    kept. ``{"t": [...], "angle_deg": {label: [...]}}``; None for a body without wheels."""
    from . import rotations as rot
    from .integrators import integrate

    if body is None:
        from .models import load_body

        body = load_body(scenario.model)
    if not body.wheels:
        return None
    wheels, applied = torque_parts(scenario, body)
    axis = wheels.h0 if np.any(wheels.h0) else np.asarray(body.wheels[0].axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    runs = {"with the wheels": (body.inertia_for(scenario.inertia), _sum(wheels, applied)),
            "wheels stopped (one rigid body)": (body.mass_inertia(scenario.inertia), applied)}
    out = {"t": None, "angle_deg": {}}
    for label, (inertia, torque) in runs.items():
        run = integrate("lie-rkmk4", inertia, scenario.q0, scenario.omega0, dt=STIFFNESS_DT,
                        duration=scenario.duration, torque=torque)
        keep = slice(None, None, max(1, -(-len(run.t) // STIFFNESS_SAMPLES)))
        start = rot.quat_rotate(run.q[0], axis)
        now = rot.quat_rotate(run.q[keep], axis)
        angle = np.degrees(np.arctan2(np.linalg.norm(np.cross(now, start), axis=-1), now @ start))
        out["t"] = run.t[keep].tolist()
        out["angle_deg"][label] = angle.tolist()
    return out


#: The largest magnetic dipole [A m^2] a scenario or a sweep's cell may give a body.
MAX_DIPOLE = 1e4


def build_torque(scenario, body):
    """The :class:`~xcheck.fields.TorqueModel` on the body of a scenario (None when torque free): the scenario's
    ``[torque]``, the one the model exerts itself (a top's gravity about its pivot, ``body.own_torque()``), or
    both, summed (:class:`~xcheck.fields.SumTorque`)."""
    return _sum(*torque_parts(scenario, body))


def torque_parts(scenario, body):
    """``(own, applied)``: the torque the model exerts itself (a top's gravity; an engine that simulates the MJCF
    exerts it on its own) and the scenario's ``[torque]``, each a :class:`~xcheck.fields.TorqueModel` or None."""
    return body.own_torque(scenario.omega0, scenario.wheel_speeds), _applied_torque(scenario, body)


def _applied_torque(scenario, body):
    from . import fields

    terms = [_torque_term(spec, scenario, body) for spec in torque_terms(scenario.torque)]
    if not terms:
        return None
    return terms[0] if len(terms) == 1 else fields.SumTorque(terms)


def _torque_term(spec: dict, scenario, body):
    from . import fields

    if spec["kind"] == "constant":
        return fields.ConstantTorque(spec["torque"])
    if spec["kind"] == "solar-pressure":
        return fields.SolarPressureTorque(**{k: v for k, v in spec.items() if k != "kind"})
    if spec["kind"] == "aerodynamic":
        return fields.AerodynamicTorque(**{k: v for k, v in spec.items() if k != "kind"})
    if spec["kind"] == "gravity-gradient":  # the whole mass's inertia, wheels included (a sweep's, where it changes)
        return fields.GravityGradientTorque(body.mass_inertia(scenario.inertia),
                                            **{k: v for k, v in spec.items() if k != "kind"})
    dipole = np.array(spec.get("dipole", body.dipole), dtype=float)
    if not np.any(dipole):
        raise ValueError(f"magnetic torque needs a dipole: none in {body.path} (<custom><numeric "
                         f"name=\"xcheck_dipole\">) and no 'dipole' key")
    if not np.linalg.norm(dipole) <= MAX_DIPOLE:  # NaN too
        raise ValueError(f"dipole: |m| = {np.linalg.norm(dipole):.3g} A m^2, beyond the {MAX_DIPOLE:.0e} A m^2 this "
                         "checks (the largest magnetorquers flown are ~1e3 A m^2; beyond, the reference spends its "
                         "whole budget on a body spun up past any rigid body's rates)")
    field = fields.FIELDS[spec["field"]]
    values = {key: spec[key] for key in field.keys if key in spec}
    torque = fields.MagneticTorque(dipole, field.from_keys(values, duration=scenario.duration))
    torque.check_span(scenario.duration)
    return torque


def check_scenario_model(scenario) -> None:
    """The model must load, and the torque must be buildable for the duration: :class:`ScenarioError` naming the
    file otherwise. Imports MuJoCo (the MJCF is MuJoCo's to read)."""
    from .models import ModelError, load_body

    try:
        body = load_body(scenario.model)
    except ModelError as exc:
        raise ScenarioError(f"{scenario.path}: model: {exc}") from None
    if scenario.wheel_speeds is not None and not body.wheels:
        raise ScenarioError(f"{scenario.path}: [initial] wheel_speeds: the model {scenario.model} has no wheels")
    try:
        body.wheel_speeds0(scenario.wheel_speeds)
    except ValueError as exc:
        raise ScenarioError(f"{scenario.path}: [initial] {exc}") from None
    try:
        torque = build_torque(scenario, body)
    except ValueError as exc:
        raise ScenarioError(f"{scenario.path}: [torque]: {exc}") from None
    if torque is not None:
        _check_torque_finite(scenario, torque)
    scenario.take_model_step(body)
    if scenario.derive:
        fill_derived(scenario, body, torque)
    if scenario.reference == "exact" and torque is not None:
        from .reference import ReferenceFailure, exact_reference, exact_why_not

        inertia = body.inertia_for(scenario.inertia)
        why = exact_why_not(inertia, torque)
        if why is None:
            try:  # Lagrange's top: its closed form must reach this motion (cheap: two times)
                exact_reference(inertia, scenario.q0, scenario.omega0, [0.0, scenario.duration], torque)
            except ReferenceFailure as exc:
                why = str(exc)
        if why is not None:
            raise ScenarioError(f"{scenario.path}: [study] reference: 'exact' is the torque-free solution, Lagrange's "
                                f"top or the axisymmetric gyrostat, and the body is under {torque.describe()}: {why}")


def _check_torque_finite(scenario, torque) -> None:
    """Refuse a torque that is not finite at the initial state, at the start, middle and end of the run (terms whose
    sizes overflow their sum, a drag of an absurd density): no solver can step through it (scipy's DOP853 spun at
    t = 0 forever on one)."""
    times = np.array([0.0, 0.5 * scenario.duration, scenario.duration])
    values = torque.many(times, scenario.q0, scenario.omega0)
    bad = np.flatnonzero(~np.all(np.isfinite(values), axis=1))
    if bad.size:
        i = int(bad[0])
        raise ScenarioError(f"{scenario.path}: [torque]: {torque.describe()} is {values[i].tolist()} N m at t = "
                            f"{times[i]:g} s from the initial state: not finite (a term's size overflows); give terms "
                            "of physical size")


def fill_derived(scenario, body, torque) -> None:
    """The steps, quick steps and limits a scenario file left out, derived from its body and motion
    (:func:`xcheck.defaults.derive`), in place; each stated among its assumptions (the report says them)."""
    d = derive(body.inertia_for(scenario.inertia), scenario.q0, scenario.omega0, scenario.duration, torque,
               your_step=body.timestep, your_step_why=body.step_source)
    said = []
    if "steps" in scenario.derive:
        scenario.steps = d.steps
        said.append(f"steps {d.why['steps']}")
    if "quick_steps" in scenario.derive:
        scenario.quick_steps = d.quick_steps
        said.append(f"quick steps {d.why['quick_steps']}")
    limits = [k for k in ("final_error", "agreement", "invariant_tolerance") if k in scenario.derive]
    for key in limits:
        scenario.checks[key] = d.final_error if key != "invariant_tolerance" else d.invariant_tolerance
    if limits and d.final_error != DEFAULT_CHECKS["final_error"]:
        said.append(f"checks' limits ({', '.join(limits)}) {d.why['final_error']}")
    scenario.assumptions = tuple(scenario.assumptions) + tuple(f"derived from the body: {s}" for s in said)
    scenario.derive = ()
