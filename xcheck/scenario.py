"""Scenarios: a TOML file becomes plain data (model, initial state, torque, study, checks).

Every input error is a :class:`ScenarioError` naming the file and the key, e.g.
``models/scenarios/x.toml: [initial] euler_angles_deg: expected 3 numbers, got 2``.
The format is documented in the README ("Scenario files").
"""

from __future__ import annotations

import math
import os
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import rotations as rot
from .base.errors import ScenarioError, UserError  # noqa: F401 (ScenarioError: read from here too)
from .defaults import (  # noqa: F401 (DEFAULT_CHECKS, the adaptive ladders: re-exported)
    ADAPTIVE_STEP,
    ADAPTIVE_TURN,
    DEFAULT_CHECKS,
    DEFAULT_TOLERANCES,
    QUICK_TOLERANCES,
    SEED_QUICK_STEPS,
    SEED_STEPS,
    default_adaptive_step,
    derive,
)
from .model_scenario import model_scenario, model_scenario_text, toml_string  # noqa: F401 (re-exported)
from .paths import BUNDLED_MODELS, MAX_INPUT_BYTES, foreign_model, input_problem
from .torque_terms import TORQUE_KINDS, copy_torque, magnetic_term, torque_terms  # noqa: F401 (re-exported)
from .trajectory import check_initial_state

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["Scenario", "ScenarioError", "load_scenario", "sidecar_of", "scenario_from_model", "model_scenario_text", "is_model_arg", "split_model_arg", "bundled_scenarios",
           "resolve_scenario", "check_name", "check_steps", "foreign_model", "torque_terms", "magnetic_term", "copy_torque", "DEFAULT_STEPS", "QUICK_STEPS", "DEFAULT_TOLERANCES", "QUICK_TOLERANCES", "ADAPTIVE_STEP",
           "ADAPTIVE_TURN", "default_adaptive_step",
           "SCENARIO_DIR"]

SCENARIO_DIR = BUNDLED_MODELS / "scenarios"
#: Seed 004 §3.3's ladder, 1/2 ... 1/4096 s, and the quick one, 1/64 ... 1/1024 s: a file's provisional steps until
#: its body's are derived (:func:`xcheck.assembly.fill_derived`)
DEFAULT_STEPS, QUICK_STEPS = SEED_STEPS, SEED_QUICK_STEPS

#: A scenario name is an identifier: it names files and folders of the report.
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,99}")


def check_name(name: str) -> str | None:
    """Why ``name`` cannot name a scenario (None when it can)."""
    if not NAME_PATTERN.fullmatch(name) or ".." in name:
        return (f"expected an identifier (letters, digits, '-', '_' and '.', starting with a letter or digit, at "
                f"most 100 characters, no '..'): it names the report's files; got {name!r}")
    return None


def check_steps(values, duration: float) -> tuple:
    """``values`` as a tuple of steps [s] that a study can run over ``duration``, or a ValueError saying
    why not: each positive, finite, at most the duration, within memory (:func:`~xcheck.trajectory.check_step`),
    and no step twice."""
    from .trajectory import check_step

    seen = set()
    for v in values:
        if v in seen:
            raise ValueError(f"the step {v:g} s is given twice")
        seen.add(v)
        check_step(v, duration)
    return tuple(values)


@dataclass
class Scenario:
    """A scenario as plain data (see the README for the TOML format)."""

    name: str
    path: Path
    model: Path
    duration: float
    q0: np.ndarray
    omega0: np.ndarray
    sequence: str = "323"
    description: str = ""
    torque: dict | None = None  # the [torque] table as read (kind, field, parameters)
    steps: tuple = DEFAULT_STEPS
    quick_steps: tuple = QUICK_STEPS
    tolerances: tuple = DEFAULT_TOLERANCES  # an adaptive method's ladder (relative tolerances)
    quick_tolerances: tuple = QUICK_TOLERANCES
    adaptive_step: float = ADAPTIVE_STEP  # an adaptive method's output step [s]
    methods: list | None = None  # None: every applicable method
    reference: str = "exact"
    reference_method: str = "lie-rkmk4"
    reference_dt: float = 1e-4
    checks: dict = field(default_factory=lambda: dict(DEFAULT_CHECKS))
    #: principal moments [kg m^2] replacing the model's, along its principal axes in MuJoCo's order
    #: (``body_inertia``); None: the model's own. Set by a sweep's inertia axes (:mod:`xcheck.sweep.spec`).
    inertia: tuple | None = None
    #: the [determination] table (:class:`xcheck.determination.sensors.DeterminationSpec`); None: the scenario has none
    determination: object = None
    #: ``[horizon]`` (issue 41): ``(duration, steps)`` [s] of ``xcheck horizon`` (:func:`_read_horizon`); None: none
    horizon: tuple | None = None
    #: a gyrostat's wheels' initial speeds relative to the body [rad/s], in the MJCF's order; None: the model's own
    #: (its first keyframe's, else zero)
    wheel_speeds: tuple | None = None
    #: what xcheck assumed to make the scenario (one from an MJCF file alone: its initial state's source, the
    #: duration, the torque, the reference, the Euler sequence; a scenario file's derived steps); the report states them
    assumptions: tuple = ()
    #: the keys the file left out that are derived from the body when the model is loaded (:func:`fill_derived`,
    #: issue 36): ``steps``, ``quick_steps``, and with the steps the checks' limits
    derive: tuple = ()
    #: what the guard found of an exact reference, once, in the process that plans the study
    #: (:func:`xcheck.study.guard_references`), with the scenario's key then (a copy changed since is checked again):
    #: the workers build the reference it chose without checking it again (a worker that drives only Basilisk never
    #: loads compiled code); None: not checked yet
    guarded: tuple | None = None
    #: where the body starts over a rotating Earth (:class:`xcheck.scoring.earth.Earth`, the ``[earth]`` table): the
    #: local NED frame a trajectory file's attitude may be relative to; None: none
    earth: object = None
    #: the trajectory files scored beside the methods (``[[trajectory]]``, :class:`xcheck.scoring.convention.Convention`)
    trajectories: tuple = ()
    #: the user's own step [s] (issue 59): the model's ``<option timestep>``, MuJoCo's default where it sets none;
    #: ``your_step_why`` says which. Derived steps include it and bracket it; the result's first line answers at it.
    #: None: not known (the model not loaded yet)
    your_step: float | None = None
    your_step_why: str = ""
    #: the model's own integrator (``<option integrator>``, as xcheck names it: euler, rk4, implicit, implicitfast):
    #: named first among MuJoCo's methods; None: not known
    your_integrator: str | None = None

    def take_model_step(self, body) -> None:
        """The model's own step and integrator (an :class:`~xcheck.models.MJCFBody`'s), as the user's."""
        self.your_step, self.your_step_why = float(body.timestep), body.step_source
        self.your_integrator = body.integrator or None


def _tolerances(st, key, default) -> tuple:
    """An adaptive ladder of relative tolerances: each in [1e-14, 0.1], none twice; loose to tight."""
    values = tuple(float(v) for v in st.get(key, "numbers", list(default)))
    if not values:
        st.fail(key, "expected at least one relative tolerance (leave the key out for the default ladder)")
    for v in values:
        if not 1e-14 <= v <= 0.1:
            st.fail(key, f"expected relative tolerances between 1e-14 and 0.1, got {v:g}")
    if len(set(values)) != len(values):
        st.fail(key, "a tolerance is given twice")
    return tuple(sorted(values, reverse=True))


class _Reader:
    """Typed access to one TOML table, with errors naming the file and the key."""

    def __init__(self, path: Path, table: dict, section: str):
        self.path, self.table, self.section = path, table, section
        self.used: set[str] = set()

    def where(self, key):
        prefix = f"[{self.section}] " if self.section else ""
        return f"{self.path}: {prefix}{key}"

    def fail(self, key, message):
        raise ScenarioError(f"{self.where(key)}: {message}")

    def has(self, key):
        return key in self.table

    def get(self, key, kind, default=None, required=False):
        self.used.add(key)
        if key not in self.table:
            if required:
                self.fail(key, "missing (required)")
            return default
        value = self.table[key]
        if kind == "number":
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                self.fail(key, f"expected a number, got {type(value).__name__} {value!r}")
            if not math.isfinite(value):
                self.fail(key, f"expected a finite number, got {value!r}")
            return float(value)
        if kind == "integer":
            if isinstance(value, bool) or not isinstance(value, int):
                self.fail(key, f"expected a whole number, got {type(value).__name__} {value!r}")
            return value
        if kind == "list":
            if not isinstance(value, list):
                self.fail(key, f"expected a list, got {type(value).__name__} {value!r}")
            return value
        if kind == "bool":
            if not isinstance(value, bool):
                self.fail(key, f"expected true or false, got {type(value).__name__} {value!r}")
            return value
        if kind == "string":
            if not isinstance(value, str):
                self.fail(key, f"expected a string, got {type(value).__name__} {value!r}")
            return value
        if kind == "strings":
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                self.fail(key, f"expected a list of strings, got {value!r}")
            return list(value)
        if kind == "table":
            if not isinstance(value, dict):
                self.fail(key, f"expected a table [{key}], got {type(value).__name__}")
            return value
        if isinstance(kind, tuple) and kind[0] == "vector":  # exactly n finite numbers
            n = kind[1]
            if not isinstance(value, list) or len(value) != n:
                self.fail(key, f"expected {n} numbers, got {value!r}")
            return np.array(self._finite_numbers(key, value), dtype=float)
        if kind == "numbers":  # a non-empty list of finite numbers
            if not isinstance(value, list) or not value:
                self.fail(key, f"expected a non-empty list of numbers, got {value!r}")
            return self._finite_numbers(key, value)
        raise AssertionError(kind)

    def _finite_numbers(self, key, values):
        for v in values:
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                self.fail(key, f"expected numbers, got {values!r}")
            if not math.isfinite(v):
                self.fail(key, f"expected finite numbers, got {values!r}")
        return [float(v) for v in values]

    def positive(self, key, default=None, required=False):
        value = self.get(key, "number", default, required)
        if value is not None and value <= 0:
            self.fail(key, f"expected a positive number, got {value!r}")
        return value

    def path_(self, key, required=False, *, limit: int = MAX_INPUT_BYTES):
        value = self.get(key, "string", None, required)
        if value is None:
            return None
        p = self.path.parent / value
        problem = input_problem(p, limit=limit)
        if problem and os.path.lexists(p) and not problem.endswith("no such file"):
            self.fail(key, problem)
        if problem:
            self.fail(key, f"no such file {value!r} (resolved to {os.path.abspath(p)})")
        return p.resolve()

    def finish(self):
        unknown = sorted(set(self.table) - self.used)
        if unknown:
            self.fail(unknown[0], f"unknown key (expected one of: {', '.join(sorted(self.used))})")


_TOP_KEYS = ("name", "description", "model", "duration", "initial", "torque", "study", "checks", "determination",
             "earth", "trajectory", "horizon")


def load_scenario(path, *, check_model: bool = True, duration: float | None = None) -> Scenario:
    """Read and validate a scenario TOML file (relative paths are relative to the file). ``check_model``: also
    load the model and build the torque (:func:`check_scenario_model`, which imports MuJoCo); the pytest plugin
    collects without it, and checks as the study starts. ``duration`` [s]: the user's (``--duration``) in place of
    the file's, its steps longer than it left out (:func:`_with_duration`)."""
    path = Path(path)
    if is_model_arg(path):
        raise ScenarioError(f"{path}: an MJCF file, not a scenario file: pass it where a scenario goes (xcheck "
                            "report MODEL.xml), or write its scenario file with xcheck init MODEL.xml")
    foreign = foreign_model(path)
    if foreign:
        raise ScenarioError(foreign)
    problem = input_problem(path, "scenario file")
    if problem:
        raise ScenarioError(problem)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read the scenario ({exc.strerror})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start}); a "
                            "scenario is a TOML file, which is UTF-8") from None
    return _parse_scenario(text, path, check_model=check_model, duration=duration)


def _with_duration(data: dict, duration: float) -> None:
    """The TOML ``data`` with the user's ``duration`` [s] in place of the file's (issue 59: ``--duration``), its
    written steps and quick steps longer than it left out (none left: the file's steps are refused, naming them)."""
    data["duration"] = float(duration)
    study = data.get("study")
    if isinstance(study, dict):
        for key in ("steps", "quick_steps"):
            values = study.get(key)
            if isinstance(values, list) and all(isinstance(v, (int, float)) for v in values):
                study[key] = [v for v in values if v <= duration] or values


def _parse_scenario(text: str, path: Path, *, check_model: bool = True, duration: float | None = None) -> Scenario:
    """A scenario from its TOML ``text``, as if read from ``path`` (relative paths are relative to its folder);
    ``duration``: the user's, in place of the file's."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None
    if duration is not None:
        _with_duration(data, duration)
    top = _Reader(path, data, "")
    for key in data:
        if key not in _TOP_KEYS:
            top.fail(key, f"unknown key (expected one of: {', '.join(_TOP_KEYS)})")
    name = top.get("name", "string", required=True)
    bad_name = check_name(name)
    if bad_name:
        top.fail("name", bad_name)
    description = top.get("description", "string", "")
    model = top.path_("model", required=True)
    duration = top.positive("duration", required=True)
    q0, omega0, sequence, wheel_speeds = _read_initial(_Reader(path, top.get("initial", "table", required=True),
                                                               "initial"))
    torque = _read_torques(top, data)
    study = _read_study(_Reader(path, top.get("study", "table", {}), "study"), duration, torque, omega0)
    earth, trajectories = _read_trajectories(top, data, study["methods"])
    checks, derive = _read_checks(_Reader(path, top.get("checks", "table", {}), "checks"), study["methods"],
                                  study.pop("derive"), files=[c.name for c in trajectories])
    determination = None
    if "determination" in data:
        from .determination.sensors import read_determination

        determination = read_determination(_Reader(path, top.get("determination", "table"), "determination"),
                                           duration, torque)

    horizon = _read_horizon(_Reader(path, top.get("horizon", "table"), "horizon")) if "horizon" in data else None
    scenario = Scenario(name=name, path=path, model=model, duration=duration, q0=q0, omega0=omega0,
                        sequence=sequence, description=description, torque=torque, checks=checks,
                        determination=determination, wheel_speeds=wheel_speeds, derive=derive, earth=earth,
                        trajectories=trajectories, horizon=horizon, **study)
    if check_model:
        from .assembly import check_scenario_model

        check_scenario_model(scenario)
    return scenario


def _read_trajectories(top: _Reader, data: dict, methods) -> tuple:
    """``[earth]`` (or None) and the ``[[trajectory]]`` files' declarations (issue 39), each name once and none a
    method's."""
    from .scoring.convention import read_convention, read_earth

    earth = read_earth(_Reader(top.path, top.get("earth", "table"), "earth")) if "earth" in data else None
    if "trajectory" not in data:
        return earth, ()
    value = top.get("trajectory", "list")
    if not value or not all(isinstance(t, dict) for t in value):
        top.fail("trajectory", f"expected [[trajectory]] tables (one for each file), got {value!r}")
    out = []
    from .runners import RUNNERS

    for k, table in enumerate(value):
        reader = _Reader(top.path, table, f"trajectory[{k}]")
        conv = read_convention(reader, earth=earth)
        if conv.name in RUNNERS or conv.name in [c.name for c in out]:
            what = "a method's name" if conv.name in RUNNERS else "another file's name"
            reader.fail("name", f"{conv.name!r} is {what}: give each file a name of its own")
        out.append(conv)
    return earth, tuple(out)


def sidecar_of(file) -> Path:
    """The sidecar declaration of the trajectory file ``file``: ``FILE.toml`` beside it."""
    file = Path(file)
    return file.with_name(file.name + ".toml")


def load_declaration(file, *, declaration=None, earth=None):
    """How to read the trajectory ``file`` outside a scenario (``xcheck score``): the ``declaration`` TOML given,
    else the sidecar ``FILE.toml`` beside it, else the defaults (xcheck's own CSV); its keys are a ``[[trajectory]]``
    table's, ``file`` left out (or naming the same file). ``earth``: the scenario's, for ``frame = "ned"``."""
    from .scoring.convention import Convention, read_convention

    file = Path(file)
    sidecar = Path(declaration) if declaration else sidecar_of(file)
    if declaration is None and not sidecar.is_file():
        return Convention(file=file.resolve(), name=file.stem)
    problem = input_problem(sidecar, "declaration")
    if problem:
        raise ScenarioError(problem)
    try:
        table = tomllib.loads(sidecar.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{sidecar}: not valid TOML: {exc}") from None
    table.setdefault("file", os.path.relpath(file.resolve(), sidecar.resolve().parent))
    reader = _Reader(sidecar, table, "")
    conv = read_convention(reader, earth=earth)
    if conv.file != file.resolve():
        reader.fail("file", f"names {conv.file}, not the file scored ({file})")
    return conv


def _read_initial(ini: _Reader) -> tuple:
    """``[initial]``: ``(q0, omega0, euler sequence, wheel speeds or None)``, from a quaternion and a body rate or
    from Euler angles and their rates (seed 001's way), checked as every initial state is."""
    euler0 = None
    sequence = "323"
    if ini.has("quaternion") and (ini.has("euler_angles_deg") or ini.has("euler_rates")):
        ini.fail("quaternion", "give either quaternion + angular_velocity, or euler_angles_deg + euler_rates, "
                               "not both")
    if ini.has("quaternion"):
        q = ini.get("quaternion", ("vector", 4))
        if ini.has("angular_velocity") == ini.has("angular_velocity_deg"):
            ini.fail("angular_velocity", "give exactly one of angular_velocity [rad/s] or angular_velocity_deg [deg/s]")
        rate_key = "angular_velocity" if ini.has("angular_velocity") else "angular_velocity_deg"
        rate = ini.get(rate_key, ("vector", 3))
        try:
            q0, omega0 = check_initial_state(q, rate if rate_key == "angular_velocity" else np.radians(rate))
        except ValueError as exc:  # the one check of an initial state, reported under the key it read
            key, _, why = str(exc).partition(": ")
            ini.fail("quaternion" if key == "q0" else rate_key, why)
        if ini.has("euler_sequence"):
            sequence = ini.get("euler_sequence", "string")
    elif ini.has("euler_angles_deg"):
        sequence = ini.get("euler_sequence", "string", "323")
        euler0 = np.radians(ini.get("euler_angles_deg", ("vector", 3)))
        rates = ini.get("euler_rates", ("vector", 3), required=True)
    else:
        ini.fail("quaternion", "missing: give either quaternion + angular_velocity, or euler_sequence + "
                               "euler_angles_deg + euler_rates")
    if sequence not in rot.EULER_SEQUENCES:
        ini.fail("euler_sequence", f"expected one of {', '.join(rot.EULER_SEQUENCES)}, got {sequence!r}")
    if euler0 is not None:
        q0 = rot.euler_to_quat(euler0, sequence)
        omega0 = rot.euler_rates_to_omega(euler0, rates, sequence)
        try:
            q0, omega0 = check_initial_state(q0, omega0)
        except ValueError as exc:
            ini.fail("euler_rates", str(exc).partition(": ")[2])
    wheel_speeds = None
    if ini.has("wheel_speeds"):
        wheel_speeds = tuple(float(v) for v in ini.get("wheel_speeds", "numbers"))
        if not all(np.isfinite(wheel_speeds)):
            ini.fail("wheel_speeds", f"expected finite speeds [rad/s], got {list(wheel_speeds)}")
    ini.finish()
    return q0, omega0, sequence, wheel_speeds


def _read_torques(top: _Reader, data: dict):
    """``[torque]`` (one table) or ``[[torque]]`` (a list of them: their sum), or None."""
    if "torque" not in data:
        return None
    value = data["torque"]
    if not isinstance(value, list):
        return _read_torque(_Reader(top.path, top.get("torque", "table"), "torque"))
    if not value or not all(isinstance(t, dict) for t in value):
        top.fail("torque", f"expected [torque] tables ([[torque]] for each term of a sum), got {value!r}")
    torque = [_read_torque(_Reader(top.path, t, f"torque[{k}]")) for k, t in enumerate(value)]
    return torque[0] if len(torque) == 1 else torque


def _read_horizon(hz: _Reader) -> tuple:
    """``[horizon]`` (issue 41): ``xcheck horizon``'s run by default, ``(duration, steps)`` [s]: steps each at most the
    duration; ``()`` without them (the three coarsest quick steps, chosen when it runs)."""
    duration, steps = hz.positive("duration", required=True), tuple(hz.get("steps", "numbers", []))
    try:
        steps = tuple(check_steps(steps, duration)) if steps else ()
    except ValueError as exc:
        hz.fail("steps", str(exc))
    hz.finish()
    return duration, steps


def _read_study(st: _Reader, duration: float, torque, omega0) -> dict:
    """``[study]``: the steps (the defaults that fit the duration where the file leaves them out: ``derive`` names
    them, for :func:`xcheck.assembly.fill_derived`), tolerances, methods and the reference."""
    steps = tuple(st.get("steps", "numbers", list(DEFAULT_STEPS)))
    quick_steps = tuple(st.get("quick_steps", "numbers", list(QUICK_STEPS)))
    if "steps" not in st.table:  # the defaults need not fit every duration: steps longer than it are dropped (and the
        steps = tuple(v for v in steps if v <= duration) or (duration,)  # body's own replace them: fill_derived)
    if "quick_steps" not in st.table:
        quick_steps = tuple(v for v in quick_steps if v <= duration) or (duration,)
    derive = tuple(k for k in ("steps", "quick_steps") if k not in st.table)
    for key, values in (("steps", steps), ("quick_steps", quick_steps)):
        try:
            check_steps(values, duration)
        except ValueError as exc:
            st.fail(key, str(exc) if key in st.table else f"the default steps do not fit: {exc}; give [study] {key}")
    tolerances = _tolerances(st, "tolerances", DEFAULT_TOLERANCES)
    quick_tolerances = _tolerances(st, "quick_tolerances", QUICK_TOLERANCES)
    adaptive_step = st.positive("adaptive_step", default_adaptive_step(omega0, duration))
    try:
        check_steps([adaptive_step], duration)
    except ValueError as exc:
        st.fail("adaptive_step", str(exc))
    methods = st.get("methods", "strings", None)
    if methods is not None and not methods:
        st.fail("methods", "expected a non-empty list of methods (leave the key out for every method)")
    reference = st.get("reference", "string", "exact")
    if reference not in ("exact", "dop853", "fine"):
        st.fail("reference", f"expected 'exact', 'dop853' or 'fine', got {reference!r}")
    if reference == "exact" and torque is not None:
        st.fail("reference", "'exact' is the torque-free solution; this scenario has a [torque]: use 'dop853' or "
                             "'fine'")
    reference_method = st.get("reference_method", "string", "lie-rkmk4")
    reference_dt = st.positive("reference_dt", 1e-4)
    if reference == "fine":
        try:
            check_steps([reference_dt], duration)
        except ValueError as exc:
            st.fail("reference_dt", str(exc))
    from .runners import RUNNERS, unknown_method

    for key, names in (("methods", methods or []), ("reference_method", [reference_method])):
        for m in names:
            if m not in RUNNERS:
                st.fail(key, unknown_method(m))
    st.finish()
    return dict(steps=steps, quick_steps=quick_steps, tolerances=tolerances, quick_tolerances=quick_tolerances,
                adaptive_step=adaptive_step, methods=methods, reference=reference,
                reference_method=reference_method, reference_dt=reference_dt, derive=derive)


def _read_checks(ck: _Reader, methods, derive: tuple, files=()) -> tuple[dict, tuple]:
    """``[checks]``: the limits (the defaults where left out) and the methods (or trajectory ``files``) expected to
    fail; ``derive`` grows by the limits that go with derived steps where the file leaves them out too."""
    from .runners import RUNNERS, unknown_method

    if "steps" in derive:
        derive += tuple(k for k in ("final_error", "agreement", "invariant_tolerance") if k not in ck.table)
    checks = dict(DEFAULT_CHECKS)
    for key in ("order_tolerance", "order_excess", "final_error", "invariant_tolerance", "agreement", "tolerance"):
        checks[key] = ck.positive(key, DEFAULT_CHECKS[key])
    checks["expected_to_fail"] = ck.get("expected_to_fail", "strings", [])
    for m in checks["expected_to_fail"]:
        if m in files:
            continue
        if m not in RUNNERS:
            ck.fail("expected_to_fail", unknown_method(m))
        if methods and m not in methods:
            ck.fail("expected_to_fail", f"{m!r} is not among the [study] methods {methods}")
    ck.finish()
    return checks, derive


#: The keys of the surface forces' [torque] tables (:mod:`xcheck.fields.surface`): key -> (shape, required).
SURFACE_KEYS = {
    "solar-pressure": {"centre_of_pressure": (("vector", 3), True), "area": ("number", True),
                       "reflectivity": ("number", False), "pressure": ("number", False),
                       "sun_direction": (("vector", 3), False)},
    "aerodynamic": {"centre_of_pressure": (("vector", 3), True), "area": ("number", True),
                    "density": ("number", False), "drag_coefficient": ("number", False),
                    "altitude_km": ("number", False), "inclination_deg": ("number", False),
                    "raan_deg": ("number", False), "arg_latitude_deg": ("number", False)},
}


def _read_torque(tq: _Reader) -> dict:
    """The [torque] table as plain values: ``kind``, and for a magnetic torque ``field``, ``dipole`` (optional)
    and the field's own keys as its declaration lists them (:data:`xcheck.fields.FIELDS`)."""
    from .fields import FIELDS

    kind = tq.get("kind", "string", required=True)
    out = {"kind": kind}
    if kind == "constant":
        out["torque"] = tq.get("torque", ("vector", 3), required=True).tolist()
    elif kind == "gravity-gradient":
        from .fields.orbit import GRAVITY_GRADIENT_KEYS

        for key in GRAVITY_GRADIENT_KEYS:
            if tq.has(key):
                out[key] = tq.get(key, "number")
    elif kind in SURFACE_KEYS:  # solar pressure, aerodynamic drag: a force through a centre of pressure
        for key, (shape, required) in SURFACE_KEYS[kind].items():
            if required or tq.has(key):
                value = tq.get(key, shape, required=True)
                out[key] = value.tolist() if isinstance(value, np.ndarray) else value
    elif kind == "magnetic":
        field_name = tq.get("field", "string", required=True)
        if field_name not in FIELDS:
            tq.fail("field", f"expected one of {', '.join(repr(n) for n in FIELDS)}, got {field_name!r}")
        out["field"] = field_name
        if tq.has("dipole"):
            out["dipole"] = tq.get("dipole", ("vector", 3)).tolist()
        for key, spec in FIELDS[field_name].keys.items():
            if not (spec.required or tq.has(key)):
                continue
            if spec.kind == "path":
                out[key] = str(tq.path_(key, required=True))
            elif spec.kind == "vector3":
                out[key] = tq.get(key, ("vector", 3), required=True).tolist()
            else:
                out[key] = tq.get(key, spec.kind, required=True)
    else:
        tq.fail("kind", f"expected one of {', '.join(repr(k) for k in TORQUE_KINDS)}, got {kind!r}")
    tq.finish()
    return out


def bundled_scenarios() -> dict[str, Path]:
    """Bundled scenario names -> files (``models/scenarios/*.toml``), in file-name order."""
    return {p.stem: p for p in sorted(SCENARIO_DIR.glob("*.toml"))}


def resolve_scenario(name_or_path, duration: float | None = None) -> Scenario:
    """A bundled scenario by name, a scenario file by path, or an MJCF file alone (``MODEL.xml``, or
    ``MODEL.xml#KEYFRAME``: :func:`scenario_from_model`); a URDF or another model format is refused, naming it
    (:func:`foreign_model`). ``duration`` [s]: the user's (``--duration``) in place of the scenario's, or of the one
    derived for a model alone."""
    bundled = bundled_scenarios()
    if str(name_or_path) in bundled:
        return load_scenario(bundled[str(name_or_path)], duration=duration)
    foreign = foreign_model(name_or_path)
    if foreign:
        raise ScenarioError(foreign)
    if is_model_arg(name_or_path):
        return scenario_from_model(name_or_path, duration)
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.exists():
        return load_scenario(path, duration=duration)
    raise ScenarioError(f"{name_or_path}: not a bundled scenario ({', '.join(bundled)}), a .toml scenario file nor "
                        "an MJCF .xml file")


# ------------------------------------------------------------------------------------------------------
# a model named alone (xcheck report MODEL.xml: the scenario is xcheck.model_scenario's), TOML text
# ------------------------------------------------------------------------------------------------------

def split_model_arg(text: str) -> tuple[Path, str | None]:
    """``MODEL.xml`` or ``MODEL.xml#KEYFRAME`` -> (path, keyframe name or None). A name ending in ``.xml`` is the
    file itself, ``#`` and all (``hash#dir/m.xml``); otherwise the keyframe follows the last ``#``."""
    text = str(text)
    if Path(text).suffix.lower() == ".xml":
        return Path(text), None
    path, sep, key = text.rpartition("#")
    return (Path(path), key) if sep else (Path(text), None)


def is_model_arg(text) -> bool:
    """Whether a scenario argument names an MJCF file (``.xml``, optionally ``#keyframe``)."""
    return split_model_arg(str(text))[0].suffix.lower() == ".xml"


def scenario_from_model(text, duration: float | None = None) -> Scenario:
    """The scenario of an MJCF file alone, ``MODEL.xml`` or ``MODEL.xml#KEYFRAME`` (see
    :func:`xcheck.model_scenario.model_scenario_text`): read as if from the file ``xcheck init`` writes, its assumptions kept for the
    report."""
    path, keyframe = split_model_arg(text)
    problem = input_problem(path, "MJCF file")
    if problem:
        raise ScenarioError(problem)
    toml_text, assumptions, body = model_scenario(path, keyframe, model_ref=str(path.resolve()), duration=duration)
    scenario = _parse_scenario(toml_text, path, check_model=False)  # loaded just now, and torque free
    scenario.assumptions = assumptions
    scenario.take_model_step(body)
    return scenario
