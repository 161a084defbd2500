"""A scenario from an MJCF file alone (``xcheck report MODEL.xml``, ``xcheck init``): the scenario file the defaults
for a model stand for (:func:`model_scenario_text`), every key present and commented, and the scenario read from it
(:func:`xcheck.scenario.scenario_from_model`), with the model's own step and integrator (issue 59)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from . import rotations as rot
from .base.errors import ScenarioError
from .defaults import (
    ADAPTIVE_TURN,
    DEFAULT_CHECKS,
    DEFAULT_TOLERANCES,
    QUICK_TOLERANCES,
    default_adaptive_step,
    derive,
)

__all__ = ["model_scenario", "model_scenario_text", "toml_string", "EULER_MARGIN_DEG"]

_TOML_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def toml_string(text: str) -> str:
    """``text`` as a TOML basic string: quotes, backslashes and control characters escaped, anything else as it
    is (UTF-8). (JSON's escapes are not TOML's: an emoji became two surrogate escapes TOML refuses.) A lone surrogate
    (a file name that is not UTF-8) is a ScenarioError: a TOML file cannot hold it."""
    out = []
    for ch in str(text):
        code = ord(ch)
        if 0xD800 <= code <= 0xDFFF:
            raise ScenarioError(f"{text!r} is not valid Unicode (a file name that is not UTF-8): a TOML file cannot "
                                "hold it")
        out.append(_TOML_ESCAPES.get(ch) or (f"\\u{code:04X}" if code < 0x20 or code == 0x7F else ch))
    return '"' + "".join(out) + '"'

#: An Euler sequence closer to its singularity than this [deg] over the run makes ``euler-rk4`` a method the
#: scenario expects to fail (it stops there: the seeds' point about Euler angles, not the model's fault).
EULER_MARGIN_DEG = 10.0


#: The [checks] keys ``xcheck init`` writes, each with its comment.
_CHECK_HELP = {"order_tolerance": "observed order at least expected minus this",
               "order_excess": "and at most expected plus this",
               "final_error": "[rad], a fourth-order method at its finest step",
               "invariant_tolerance": "relative energy and momentum drift",
               "agreement": "[rad], an engine's RK4 against our best",
               "tolerance": "[rad], the largest attitude error over the run you accept at your step (the first line)"}


def _toml_list(values) -> str:
    return "[" + ", ".join(repr(float(v)) for v in values) + "]"


def _euler_margins(inertia, q0, omega0, duration: float, torque=None, reference: str = "exact") -> dict:
    """Per Euler sequence, the smallest distance [deg] of its middle angle from the singularity over the motion
    (the exact solution, or DOP853's under a torque that has none, on 401 times)."""
    from .reference import dop853_solution, exact_reference

    t = np.linspace(0.0, duration, 401)
    if reference == "exact":
        q, _ = exact_reference(inertia, q0, omega0, t, torque)
    else:
        q, _ = dop853_solution(inertia, q0, omega0, duration, torque=torque)(t)
    out = {}
    for seq in rot.EULER_SEQUENCES:
        middle = rot.quat_to_euler(q, seq, warn=False)[:, 1]
        margin = np.minimum(middle, np.pi - middle) if seq[0] == seq[2] else np.pi / 2 - np.abs(middle)
        out[seq] = float(np.degrees(margin.min()))
    return out


def model_scenario_text(model, keyframe: str | None = None, *, model_ref: str | None = None,
                        duration: float | None = None) -> tuple[str, tuple]:
    """:func:`model_scenario` without the body."""
    return model_scenario(model, keyframe, model_ref=model_ref, duration=duration)[:2]


def model_scenario(model, keyframe: str | None = None, *, model_ref: str | None = None,
                   duration: float | None = None) -> tuple[str, tuple, object]:
    """The scenario file that the defaults for an MJCF file stand for, every key present and commented (what
    ``xcheck init`` writes and what ``xcheck report MODEL.xml`` runs), and the assumptions it makes, in words
    (the report states them). ``model_ref``: the model as the file names it (relative to where it is written;
    default: the path as given); ``duration`` [s] the user's (``--duration``; default: derived from the motion); and its body (:class:`~xcheck.models.MJCFBody`). :class:`ScenarioError` naming the
    file for a model xcheck cannot check (its refusal) or a keyframe it does not have."""
    from .models import ModelError, initial_state
    from .reference import ReferenceFailure

    model = Path(model)
    try:
        state = initial_state(model, keyframe)
    except ModelError as exc:
        raise ScenarioError(str(exc)) from None
    body = state.body
    stem = model.stem + (f"-{state.keyframe or keyframe}" if keyframe is not None else "")
    name = re.sub(r"[^A-Za-z0-9_.-]+|\.{2,}", "-", stem).strip("-._")[:100] or "model"  # check_name's identifier
    from .reference import exact_why_not

    own = body.own_torque(state.omega0, state.wheel_speeds)
    why_not = exact_why_not(body.inertia, own)
    reference = "exact" if why_not is None else "dop853"
    derived = derive(body.inertia, state.q0, state.omega0, duration, own, your_step=body.timestep,
                     your_step_why=body.step_source)  # steps, duration and limits from the body, and the model's step
    duration = derived.duration
    margins = None
    try:
        margins = _euler_margins(body.inertia, state.q0, state.omega0, duration, own, reference)
    except ReferenceFailure as exc:
        if own is None:
            margins = exc
        else:  # a top whose closed form does not reach this motion (its axis at the vertical): DOP853
            reference, why_not = "dop853", str(exc)
    except ValueError as exc:
        margins = exc
    if own is None:
        torque_words = "torque free (the model declares no torque)"
        reference_words = "reference: the exact torque-free solution (closed form)"
    else:
        torque_words = f"the model's own torque only: {own.describe()}"
        exact_words = ("the exact axisymmetric gyrostat (closed form)" if body.wheels
                       else "the exact heavy symmetric top (Lagrange's, closed form)")
        reference_words = (f"reference: {exact_words}" if reference == "exact"
                           else f"reference: DOP853 at rtol 1e-13 ({why_not})")
    assumptions = [f"initial state: {state.source}", *state.notes, *body.notes,
                   f"duration {derived.why.get('duration', f'{derived.duration:g} s: yours (--duration)')}; "
                   f"{torque_words}", reference_words,
                   f"steps {derived.why['steps']}", f"quick steps {derived.why['quick_steps']}",
                   *([f"the checks' limits {derived.why['final_error']}"]
                     if derived.final_error != DEFAULT_CHECKS["final_error"] else [])]
    expected_to_fail, sequence = [], "323"
    try:
        if margins is None:
            margins = _euler_margins(body.inertia, state.q0, state.omega0, duration, own, reference)
        if isinstance(margins, Exception):
            raise margins
    except (ReferenceFailure, ValueError) as exc:
        assumptions.append(f"euler-rk4's sequence: 323, unchecked ({exc})")
    else:
        sequence = max(rot.EULER_SEQUENCES, key=lambda s: (margins[s], s == "323"))
        if margins[sequence] < EULER_MARGIN_DEG:
            expected_to_fail = ["euler-rk4"]
            assumptions.append(f"euler-rk4 is expected to fail: every Euler sequence comes within "
                               f"{margins[sequence]:.1f} deg of its singularity in this motion (323 is kept)")
            sequence = "323"
        else:
            assumptions.append(f"euler-rk4's sequence: {sequence}, the one farthest from its singularity over the "
                               f"run ({margins[sequence]:.1f} deg)")
    checks = dict(DEFAULT_CHECKS, final_error=derived.final_error, agreement=derived.final_error,
                  invariant_tolerance=derived.invariant_tolerance)
    ref = model_ref if model_ref is not None else str(model)
    fail_list = "[" + ", ".join(f'"{m}"' for m in expected_to_fail) + "]"
    lines = [
        f"# A scenario of {model.name}, as xcheck assumes it when given the model alone (xcheck init): every key of a",
        "# scenario file, with its value for this model. Edit what you know better; xcheck report THIS_FILE runs it.",
        *(f"#   - {a}" for a in assumptions),
        f"name = {toml_string(name)}",
        f"description = {toml_string(f'{model.name}, ' + state.source.split(':')[0] + (', torque free' if own is None else ', with wheels' if body.wheels else ', a top under gravity'))}",
        f"model = {toml_string(ref)}   # the MJCF file (relative to this file)",
        f"duration = {duration!r}   # [s], "
        + (f"derived: {derived.why['duration']}" if "duration" in derived.why else "yours (--duration)"),
        "",
        "[initial]",
        f"# {state.source}",
        f"quaternion = {_toml_list(state.q0)}   # [w, x, y, z], body -> world",
        f"angular_velocity = {_toml_list(state.omega0)}   # [rad/s], body frame",
        f"euler_sequence = {toml_string(sequence)}   # the sequence euler-rk4 integrates",
        *([f"wheel_speeds = {_toml_list(state.wheel_speeds)}   # [rad/s], each wheel's relative to the body "
           f"({', '.join(w.name for w in body.wheels)})"] if body.wheels else []),
        "",
        "# [torque]   # none: torque free. A constant torque [N m] in body components:",
        "# kind = \"constant\"",
        "# torque = [0.0, 0.0, 1e-4]",
        "# or a magnetic dipole in a field (kind = \"magnetic\", field = \"uniform\" | \"orbit-dipole\" | \"igrf\" | ...; see",
        "# docs/scenarios.md); with a torque, the reference is \"dop853\".",
        "",
        "[study]",
        f"reference = \"{reference}\"   # \"exact\": the closed form (torque free, Lagrange's top, the axisymmetric gyrostat); else \"dop853\" "
        "or \"fine\"",
        f"steps = {_toml_list(derived.steps)}   # [s], the full study; derived: {derived.why['steps']}",
        f"quick_steps = {_toml_list(derived.quick_steps)}   # [s], --quick; derived: {derived.why['quick_steps']}",
        f"tolerances = {_toml_list(DEFAULT_TOLERANCES)}   # an adaptive method's ladder (relative tolerances)",
        f"quick_tolerances = {_toml_list(QUICK_TOLERANCES)}",
        f"adaptive_step = {default_adaptive_step(state.omega0, duration)!r}   # [s], an adaptive method's output "
        f"step (it turns the body by at most {ADAPTIVE_TURN:g} rad at the initial rate)",
        "# methods = [\"lie-rkmk4\", \"mujoco-rk4\"]   # every method when left out (xcheck list)",
        "reference_method = \"lie-rkmk4\"   # for reference = \"fine\"",
        "reference_dt = 0.0001   # [s], for reference = \"fine\"",
        "",
        "[checks]",
        *(f"{k} = {checks[k]!r}   # {why}" + (f"; derived: {derived.why['final_error']}"
                                               if k in ("final_error", "agreement", "invariant_tolerance") else "")
          for k, why in _CHECK_HELP.items()),
        f"expected_to_fail = {fail_list}",
        "",
    ]
    return "\n".join(lines), tuple(assumptions), body
