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
from .defaults import DEFAULT_CHECKS, SEED_QUICK_STEPS, SEED_STEPS, derive  # noqa: F401 (DEFAULT_CHECKS: re-exported)
from .paths import BUNDLED_MODELS, MAX_INPUT_BYTES, foreign_model, input_problem
from .torque_terms import TORQUE_KINDS, copy_torque, magnetic_term, torque_terms  # noqa: F401 (re-exported)
from .trajectory import check_initial_state

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["Scenario", "ScenarioError", "load_scenario", "scenario_from_model",
           "model_scenario_text", "is_model_arg", "bundled_scenarios",
           "resolve_scenario", "check_name", "check_steps", "foreign_model", "torque_terms", "magnetic_term", "copy_torque", "DEFAULT_STEPS", "QUICK_STEPS", "DEFAULT_TOLERANCES", "QUICK_TOLERANCES", "ADAPTIVE_STEP",
           "ADAPTIVE_TURN", "default_adaptive_step",
           "SCENARIO_DIR"]

SCENARIO_DIR = BUNDLED_MODELS / "scenarios"
#: Seed 004 §3.3's ladder, 1/2 ... 1/4096 s, and the quick one, 1/64 ... 1/1024 s: a file's provisional steps until
#: its body's are derived (:func:`xcheck.assembly.fill_derived`)
DEFAULT_STEPS, QUICK_STEPS = SEED_STEPS, SEED_QUICK_STEPS
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


def load_scenario(path, *, check_model: bool = True) -> Scenario:
    """Read and validate a scenario TOML file (relative paths are relative to the file). ``check_model``: also
    load the model and build the torque (:func:`check_scenario_model`, which imports MuJoCo); the pytest plugin
    collects without it, and checks as the study starts."""
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
    return _parse_scenario(text, path, check_model=check_model)


def _parse_scenario(text: str, path: Path, *, check_model: bool = True) -> Scenario:
    """A scenario from its TOML ``text``, as if read from ``path`` (relative paths are relative to its folder)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None
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


def load_declaration(file, *, declaration=None, earth=None):
    """How to read the trajectory ``file`` outside a scenario (``xcheck score``): the ``declaration`` TOML given,
    else the sidecar ``FILE.toml`` beside it, else the defaults (xcheck's own CSV); its keys are a ``[[trajectory]]``
    table's, ``file`` left out (or naming the same file). ``earth``: the scenario's, for ``frame = "ned"``."""
    from .scoring.convention import Convention, read_convention

    file = Path(file)
    sidecar = Path(declaration) if declaration else file.with_name(file.name + ".toml")
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
    for key in ("order_tolerance", "order_excess", "final_error", "invariant_tolerance", "agreement"):
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


def resolve_scenario(name_or_path) -> Scenario:
    """A bundled scenario by name, a scenario file by path, or an MJCF file alone (``MODEL.xml``, or
    ``MODEL.xml#KEYFRAME``: :func:`scenario_from_model`); a URDF or another model format is refused, naming it
    (:func:`foreign_model`)."""
    bundled = bundled_scenarios()
    if str(name_or_path) in bundled:
        return load_scenario(bundled[str(name_or_path)])
    foreign = foreign_model(name_or_path)
    if foreign:
        raise ScenarioError(foreign)
    if is_model_arg(name_or_path):
        return scenario_from_model(name_or_path)
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.exists():
        return load_scenario(path)
    raise ScenarioError(f"{name_or_path}: not a bundled scenario ({', '.join(bundled)}), a .toml scenario file nor "
                        "an MJCF .xml file")


# ------------------------------------------------------------------------------------------------------
# a scenario from an MJCF file alone (xcheck report MODEL.xml, xcheck init)
# ------------------------------------------------------------------------------------------------------
#: An Euler sequence closer to its singularity than this [deg] over the run makes ``euler-rk4`` a method the
#: scenario expects to fail (it stops there: the seeds' point about Euler angles, not the model's fault).
EULER_MARGIN_DEG = 10.0


#: The [checks] keys ``xcheck init`` writes, each with its comment.
_CHECK_HELP = {"order_tolerance": "observed order at least expected minus this",
               "order_excess": "and at most expected plus this",
               "final_error": "[rad], a fourth-order method at its finest step",
               "invariant_tolerance": "relative energy and momentum drift",
               "agreement": "[rad], an engine's RK4 against our best"}


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


def model_scenario_text(model, keyframe: str | None = None, *, model_ref: str | None = None) -> tuple[str, tuple]:
    """The scenario file that the defaults for an MJCF file stand for, every key present and commented (what
    ``xcheck init`` writes and what ``xcheck report MODEL.xml`` runs), and the assumptions it makes, in words
    (the report states them). ``model_ref``: the model as the file names it (relative to where it is written;
    default: the path as given). :class:`ScenarioError` naming the file for a model xcheck cannot check (its
    refusal) or a keyframe it does not have."""
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
    derived = derive(body.inertia, state.q0, state.omega0, None, own)  # steps, duration and limits from the body
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
                   f"duration {derived.why['duration']}; {torque_words}", reference_words,
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
        f"duration = {duration!r}   # [s], derived: {derived.why['duration']}",
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
    return "\n".join(lines), tuple(assumptions)


def scenario_from_model(text) -> Scenario:
    """The scenario of an MJCF file alone, ``MODEL.xml`` or ``MODEL.xml#KEYFRAME`` (see
    :func:`model_scenario_text`): read as if from the file ``xcheck init`` writes, its assumptions kept for the
    report."""
    path, keyframe = split_model_arg(text)
    problem = input_problem(path, "MJCF file")
    if problem:
        raise ScenarioError(problem)
    toml_text, assumptions = model_scenario_text(path, keyframe, model_ref=str(path.resolve()))
    scenario = _parse_scenario(toml_text, path, check_model=False)  # loaded just now, and torque free
    scenario.assumptions = assumptions
    return scenario
