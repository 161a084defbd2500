"""Sweep specs (issue 12, first step): a base scenario, the axes to vary, and the cells they make.

A spec is a TOML file::

    base = "rax1-orbit-field"        # a bundled scenario, or a scenario file (relative to the spec)
    combine = "product"              # "product": every combination of the axes' values; "sample": `samples`
    samples = 200                    #   draws, each axis from its distribution
    seed = 7                         # every random draw comes from it (and the axis' name)
    methods = ["formulation-2", "lie-rkmk4"]   # optional: the cells' methods (default: the base's)

    [axes.dipole_scale]              # an axis: explicit values ...
    values = [0.5, 1.0, 2.0]
    [axes.inertia_scale]             # ... or a range (num points, linear or log spacing) ...
    range = [0.5, 2.0]
    num = 4
    spacing = "log"
    [axes.attitude]                  # ... or random draws (count of them in a product; one per sample)
    random = "so3"
    count = 10
    [axes.dt]                        # the steps every cell runs (not a product dimension: each cell runs all)
    values = [0.0625, 0.03125, 0.015625]

With ``combine = "sample"`` a numeric axis draws from ``distribution = "uniform" | "log-uniform"`` over its
``range``, or ``"normal"`` with ``mean`` and ``std``; an axis with ``values`` draws one of them.

Axes (:data:`AXES`): ``model`` (MJCF files: swap the body), ``inertia_scale``, ``inertia`` (principal moments
[kg m²]), ``dipole`` [A m²], ``dipole_scale``, ``attitude`` (quaternions ``[w, x, y, z]``, or ``random =
"so3"``: uniform on SO(3)), ``rate`` [rad/s] or ``rate_deg`` [deg/s] (vectors), ``rate_scale`` (the base
rate times a factor: stiffen the spin), ``rate_direction`` (``random = "sphere"``: the base rate's magnitude
along a uniformly random direction), ``field`` (a field model name), ``field.<key>`` (that field model's
parameter, e.g. ``field.altitude_km``), and ``dt``. An axis the base scenario has nothing to vary for (a
dipole of a torque-free scenario, a field key its field model does not have) is refused.

Everything is checked when the spec is read, before any cell runs: an unknown axis or key, an empty range,
a value of the wrong kind is a :class:`SweepError` naming the file and the key.
"""

from __future__ import annotations

import hashlib
import json
import math
import zlib
from dataclasses import dataclass, field
from itertools import product
from pathlib import Path
from typing import Callable

import numpy as np

from ..torque_terms import copy_torque, magnetic_term, torque_terms
from ..scenario import Scenario, ScenarioError, _Reader, is_model_arg, resolve_scenario

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

__all__ = ["MAX_CELLS", "SweepError", "SweepSpec", "Axis", "AxisKind", "AXES", "load_sweep", "resolve_sweep",
           "bundled_sweeps", "apply_cell", "flat_params", "random_quaternions", "random_directions"]


class SweepError(ScenarioError):
    """A sweep spec that cannot be used; the message names the file and the key."""


#: axis name -> (kind of one value, what it varies). Kinds: number, positive, vector3, positive3, quaternion,
#: path, string, strings, kinds (a list of torque kinds).
@dataclass(frozen=True)
class AxisKind:
    """A sweep axis as declared: the kind of its values (how the spec is read and checked), its help text, and
    how a cell's value changes the base scenario (``apply(scenario, value, body)``, ``body()`` the cell's model
    loaded on demand; None: the value is not the scenario's, ``dt`` is the run's)."""

    kind: str
    help: str
    apply: Callable | None = None


def _set(attr: str, convert):
    def apply(sc, value, body):
        setattr(sc, attr, convert(value))
    return apply


def _inertia_scale(sc, value, body):
    moments = sc.inertia if sc.inertia is not None else body().model_moments
    sc.inertia = tuple(value * m for m in moments)


def _dipole(sc, value, body):
    magnetic_term(sc.torque)["dipole"] = list(value)


def _dipole_scale(sc, value, body):
    term = magnetic_term(sc.torque)
    term["dipole"] = [value * float(m) for m in term.get("dipole", body().dipole)]


def _field(sc, value, body):
    from ..fields import FIELDS

    keys = FIELDS[value].keys
    term = magnetic_term(sc.torque)
    kept = {k: v for k, v in term.items() if k in ("kind", "dipole") or k in keys}
    term.clear()
    term.update(kept, field=value)


def _torques(sc, value, body):
    """Keep the base's torque terms of the kinds listed (each term on or off; [] torque free)."""
    terms = [t for t in torque_terms(sc.torque) if t["kind"] in value]
    sc.torque = None if not terms else terms[0] if len(terms) == 1 else terms


def _wheel_speed_scale(sc, value, body):
    sc.wheel_speeds = tuple(value * s for s in body().wheel_speeds0(sc.wheel_speeds))


def _rate_direction(sc, value, body):
    d = np.asarray(value, dtype=float)
    d = d / np.max(np.abs(d))  # first to the order of 1: a norm of 1e-320 or 1e308 squared under- or overflows
    sc.omega0 = np.linalg.norm(sc.omega0) * d / np.linalg.norm(d)


#: Every axis a spec may have, in the order a cell applies them: the model first (its inertia and dipole are what
#: the scales scale), then inertia, dipole, field (then the field's own keys, ``field.<key>``), attitude, rate.
AXES = {
    "model": AxisKind("path", "the MJCF model (swap the body)", _set("model", Path)),
    "inertia": AxisKind("positive3", "the body's principal moments of inertia [kg m^2]", _set("inertia", tuple)),
    "inertia_scale": AxisKind("positive", "the body's inertia times a factor", _inertia_scale),
    "dipole": AxisKind("vector3", "the magnetic dipole [A m^2]", _dipole),
    "dipole_scale": AxisKind("positive", "the dipole times a factor", _dipole_scale),
    "field": AxisKind("string", "the field model", _field),
    "attitude": AxisKind("quaternion", "the initial attitude [w, x, y, z], body -> world",
                         _set("q0", lambda v: np.asarray(v, dtype=float) / np.linalg.norm(v))),
    "rate": AxisKind("vector3", "the initial body rate [rad/s]", _set("omega0", lambda v: np.asarray(v, dtype=float))),
    "rate_deg": AxisKind("vector3", "the initial body rate [deg/s]",
                         _set("omega0", lambda v: np.radians(np.asarray(v, dtype=float)))),
    "rate_scale": AxisKind("positive", "the initial body rate times a factor",
                           lambda sc, v, body: setattr(sc, "omega0", v * sc.omega0)),
    "rate_direction": AxisKind("vector3", "the initial body rate's direction (its magnitude kept)", _rate_direction),
    "wheel_speed_scale": AxisKind("positive", "a gyrostat's wheels' initial speeds times a factor (their momentum)",
                                  _wheel_speed_scale),
    "torques": AxisKind("kinds", "the base's torque terms kept, by kind (a list each: [\"magnetic\", "
                                 "\"gravity-gradient\"], or [] for none): each term on or off", _torques),
    "dt": AxisKind("positive", "the steps every cell runs [s]"),
}
RANDOM = {"attitude": "so3", "rate_direction": "sphere"}
_AXIS_KEYS = ("values", "range", "num", "spacing", "distribution", "mean", "std", "random", "count")
_TOP_KEYS = ("base", "description", "combine", "samples", "seed", "methods", "axes")
MAGNETIC_AXES = ("dipole", "dipole_scale", "field")


@dataclass
class Axis:
    name: str
    kind: str
    values: list | None = None  # explicit (or a range, spaced)
    low: float | None = None
    high: float | None = None
    num: int | None = None
    spacing: str = "linear"
    distribution: str | None = None  # sample mode
    mean: float | None = None
    std: float | None = None
    random: str | None = None  # "so3" | "sphere"
    count: int | None = None

    def grid(self, seed: int) -> list:
        """The axis' values in a Cartesian product."""
        if self.random:
            return list(_random_axis(self.random, self.count, _rng(seed, self.name)))
        if self.values is not None:
            return list(self.values)
        if self.spacing == "log":
            return np.geomspace(self.low, self.high, self.num).tolist()
        return np.linspace(self.low, self.high, self.num).tolist()

    def draw(self, n: int, seed: int) -> list:
        """``n`` draws (sample mode), reproducible from ``seed`` and the axis' name."""
        rng = _rng(seed, self.name)
        if self.random:
            return list(_random_axis(self.random, n, rng))
        if self.values is not None:
            return [self.values[i] for i in rng.integers(0, len(self.values), n)]
        if self.distribution == "normal":
            out = rng.normal(self.mean, self.std, n)
        elif self.distribution == "log-uniform":
            out = np.exp(rng.uniform(np.log(self.low), np.log(self.high), n))
        else:
            out = rng.uniform(self.low, self.high, n)
        return out.tolist()


def _rng(seed: int, name: str) -> np.random.Generator:
    """The generator of one axis: from the spec's seed and the axis' name, so that adding or reordering axes
    leaves the others' draws as they were."""
    return np.random.default_rng([seed, zlib.crc32(name.encode())])


def random_quaternions(n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` attitudes uniform on SO(3): normalised 4-D Gaussians (uniform on S³, hence Haar on SO(3)), w ≥ 0."""
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return np.where(q[:, :1] < 0, -q, q)


def random_directions(n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` unit vectors uniform on the sphere."""
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _random_axis(kind: str, n: int, rng) -> list:
    return (random_quaternions if kind == "so3" else random_directions)(n, rng).tolist()


@dataclass
class SweepSpec:
    path: Path
    base: Scenario
    combine: str
    axes: list[Axis]
    seed: int = 0
    samples: int | None = None
    methods: list | None = None
    steps: tuple = ()
    description: str = ""
    cells: list[dict] = field(default_factory=list)


def cell_id(params: dict) -> str:
    """A cell's name: a digest of its parameters (stable across runs: what ``--resume`` matches)."""
    text = json.dumps(params, sort_keys=True, default=str)
    return hashlib.sha1(text.encode()).hexdigest()[:12]


def bundled_sweeps() -> dict[str, Path]:
    """Bundled sweep names -> files (``models/sweeps/*.toml``)."""
    from ..paths import BUNDLED_MODELS

    return {p.stem: p for p in sorted((BUNDLED_MODELS / "sweeps").glob("*.toml"))}


#: The largest sweep read without a larger ``max_cells`` (``xcheck sweep --max-cells``): a day of cells on a
#: laptop; a spec whose size is a slip (three axes of ``num = 1000``) is refused before it allocates anything.
MAX_CELLS = 100_000


def resolve_sweep(name_or_path, *, max_cells: int | None = MAX_CELLS) -> SweepSpec:
    """A bundled sweep by name, or a sweep spec by path (see :func:`load_sweep`)."""
    bundled = bundled_sweeps()
    if str(name_or_path) in bundled and not Path(name_or_path).exists():
        return load_sweep(bundled[str(name_or_path)], max_cells=max_cells)
    if Path(name_or_path).suffix != ".toml" and not Path(name_or_path).exists():
        raise SweepError(f"{name_or_path}: not a bundled sweep ({', '.join(bundled)}) nor a .toml file")
    return load_sweep(name_or_path, max_cells=max_cells)


def load_sweep(path, *, max_cells: int | None = MAX_CELLS) -> SweepSpec:
    """Read and check a sweep spec; its cells are generated (``.cells``: ``{"id", "params"}``). A spec of more
    than ``max_cells`` cells (None: no limit) is refused before any cell or axis value is built."""
    from ..paths import input_problem

    path = Path(path)
    problem = input_problem(path, "sweep spec")
    if problem:
        raise SweepError(problem)
    try:
        data = tomllib.loads(path.read_bytes().decode("utf-8-sig"))
    except OSError as exc:
        raise SweepError(f"{path}: cannot read the sweep spec ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise SweepError(f"{path}: not UTF-8 text; a sweep spec is a TOML file") from None
    except tomllib.TOMLDecodeError as exc:
        raise SweepError(f"{path}: not valid TOML: {exc}") from None
    top = _Reader(path, data, "")
    try:
        return _read(path, top, data, max_cells)
    except SweepError:
        raise
    except ScenarioError as exc:  # the _Reader's own messages (file and key already in them)
        raise SweepError(str(exc)) from None


def _sizes(axes: list[Axis]) -> list[int]:
    """Each axis' number of values in a product, from the spec alone (nothing is built)."""
    return [a.count if a.random else len(a.values) if a.values is not None else a.num for a in axes]


def _read(path: Path, top: _Reader, data: dict, max_cells: int | None = None) -> SweepSpec:
    from ..runners import RUNNERS, unknown_method

    for key in data:
        if key not in _TOP_KEYS:
            top.fail(key, f"unknown key (expected one of: {', '.join(_TOP_KEYS)})")
    base_text = top.get("base", "string", required=True)
    relative = path.parent / base_text  # a scenario file or an MJCF model (MODEL.xml#KEY), beside the spec
    try:
        base = resolve_scenario(relative if relative.suffix == ".toml" or is_model_arg(base_text) else base_text)
    except ScenarioError as exc:
        top.fail("base", f"the base scenario cannot be used: {exc}")
    combine = top.get("combine", "string", "product")
    if combine not in ("product", "sample"):
        top.fail("combine", f"expected 'product' or 'sample', got {combine!r}")
    seed = top.get("seed", "integer", 0)
    if seed < 0:
        top.fail("seed", f"expected a non-negative integer, got {seed}")
    samples = None
    if combine == "sample":
        samples = top.get("samples", "integer", required=True)
        if samples < 1:
            top.fail("samples", f"expected a positive number of cells, got {samples}")
    elif top.has("samples"):
        top.fail("samples", "only with combine = \"sample\"")
    methods = top.get("methods", "strings", None)
    for m in methods or ():
        if m not in RUNNERS:
            top.fail("methods", unknown_method(m))
    if methods is not None and not methods:
        top.fail("methods", "an empty list: name at least one method")
    axes_table = top.get("axes", "table", required=True)
    if not axes_table:
        top.fail("axes", "no axis: a sweep varies at least one")
    axes = [_read_axis(path, name, table, base, combine) for name, table in axes_table.items()]
    if combine == "sample":
        size, what = samples, f"samples = {samples:,}"
    else:  # the product's cells, and any one axis' values (a dt axis is steps, not cells)
        sizes = _sizes(axes)
        size = max(math.prod(n for a, n in zip(axes, sizes) if a.name != "dt"), *sizes)
        what = " x ".join(f"{a.name} {n:,}" for a, n in zip(axes, sizes))
    if max_cells is not None and size > max_cells:
        top.fail("samples" if combine == "sample" else "axes",
                 f"{size:,} cells ({what}), more than the limit of {max_cells:,}: give --max-cells {size} to run "
                 "it anyway")
    for a in axes:
        _check_axis_against_base(path, a, base, seed)
    steps = base.quick_steps
    dt_axis = next((a for a in axes if a.name == "dt"), None)
    if dt_axis is not None:
        steps = tuple(sorted(set(dt_axis.grid(seed)), reverse=True))
        axes = [a for a in axes if a.name != "dt"]
    spec = SweepSpec(path=path, base=base, combine=combine, axes=axes, seed=seed, samples=samples,
                     methods=methods, steps=steps, description=top.get("description", "string", ""))
    if not axes and combine == "product":
        spec.cells = [{"id": cell_id({}), "params": {}}]
    elif combine == "product":
        grids = [a.grid(seed) for a in axes]
        spec.cells = [_cell(dict(zip((a.name for a in axes), combo))) for combo in product(*grids)]
    else:
        draws = [a.draw(samples, seed) for a in axes]
        for a, d in zip(axes, draws):  # a distribution's draws are what will run: their extremes are checked too
            if a.distribution is not None:
                _check_axis_against_base(path, a, base, seed, probes=[min(d), max(d)])
        spec.cells = [_cell({a.name: d[i] for a, d in zip(axes, draws)}) for i in range(samples)]
    _check_states(spec)
    return spec


#: The axes that set a cell's initial state (its attitude, body rate, wheel speeds).
STATE_AXES = ("attitude", "rate", "rate_deg", "rate_scale", "rate_direction", "wheel_speed_scale")


def _check_states(spec: SweepSpec) -> None:
    """Refuse, before any cell runs, a cell whose initial state no body can have: a rate past
    :data:`xcheck.body.MAX_RATE` (a scale of 1e308 overflows to inf), wheels spun past it. Each distinct combination of
    the state axes' values is checked once (a product's other axes repeat them)."""
    from ..trajectory import check_initial_state

    seen = set()
    for cell in spec.cells:
        state = {k: v for k, v in cell["params"].items() if k in STATE_AXES}
        key = json.dumps(state, sort_keys=True)
        if not state or key in seen:
            continue
        seen.add(key)
        with np.errstate(all="ignore"):
            sc = apply_cell(spec.base, state)
        try:
            check_initial_state(sc.q0, sc.omega0)
            if "wheel_speed_scale" in state:
                from ..models import load_body

                load_body(sc.model).wheel_speeds0(sc.wheel_speeds)
        except ValueError as exc:
            axes = ", ".join(f"{k} = {v}" for k, v in state.items())
            raise SweepError(f"{spec.path}: [axes] the cell {axes} starts from no state a body can have: "
                             f"{exc}") from None


def _check_axis_against_base(path: Path, axis: Axis, base: Scenario, seed: int, probes=None) -> None:
    """Refuse, before anything runs, an axis value the base scenario cannot take: a model xcheck cannot load
    (or without the dipole the base's magnetic torque needs), inertia no rigid body has, a field model without
    a key it requires, a scale of a zero rate, a field parameter its model refuses."""
    from ..body import validate_inertia
    from ..models import ModelError, load_body

    def refuse(message):
        raise SweepError(f"{path}: [axes.{axis.name}] {message}")

    if axis.name in ("rate_scale", "rate_direction") and not np.any(base.omega0):
        refuse(f"the base scenario {base.name} starts at rest: there is no rate to scale or turn")
    if axis.name in ("inertia", "inertia_scale", "wheel_speed_scale"):
        from ..models import load_body

        base_body = load_body(base.model)
        wheels = base_body.wheels
        if wheels and axis.name != "wheel_speed_scale":
            refuse(f"the base's model {base.model} has wheels: its inertia is not swept (MuJoCo's bus alone would "
                   "change, not the whole body's); swap the model instead (a model axis)")
        if base_body.parts > 1 and axis.name != "wheel_speed_scale":
            refuse(f"the base's model {base.model} is built from {base_body.parts} parts: its inertia is not swept "
                   "(MuJoCo's first part alone would change, not the whole body's: a heavy top's axle kept its own); "
                   "swap the model instead (a model axis)")
        if not wheels and axis.name == "wheel_speed_scale":
            refuse(f"the base's model {base.model} has no wheels")
    if axis.name == "dt":
        from ..scenario import check_steps

        try:
            check_steps(sorted(set(axis.grid(seed)), reverse=True), base.duration)
        except ValueError as exc:
            refuse(f"{exc} (the base's duration is {base.duration:g} s)")
        return
    if axis.name == "rate_direction":
        zero = [v for v in axis.values or () if not np.any(v)]
        if zero:
            refuse(f"{zero[0]} is no direction: give vectors of non-zero length")
    if axis.random or axis.name in ("attitude", "rate", "rate_deg", "rate_direction"):
        return  # any unit quaternion and any rate are a state
    if probes is None:
        probes = axis.values if axis.values is not None else [v for v in (axis.low, axis.high) if v is not None]
    for value in probes:
        if axis.name == "inertia":
            try:
                validate_inertia(value)
            except ValueError as exc:
                refuse(f"{value}: {str(exc).removeprefix('inertia: ')}")
        if axis.name == "field":
            from ..fields import FIELDS

            missing = [k for k, key in FIELDS[value].keys.items() if key.required and k not in magnetic_term(base.torque)]
            if missing:
                refuse(f"the field model {value!r} needs {', '.join(missing)}, which the base's [torque] does not "
                       "give")
        if axis.name in ("model", "field", "inertia", "inertia_scale") or axis.name.startswith("field.") or \
                "dipole" in axis.name:
            from ..assembly import check_scenario_model

            sc = apply_cell(base, {axis.name: value})
            try:  # the model loads, its wheels take the base's speeds, the torque builds, the reference can be had
                check_scenario_model(sc)
            except ModelError as exc:  # names the file already
                refuse(str(exc))
            except ScenarioError as exc:
                refuse(f"{value!r}: {str(exc).removeprefix(f'{sc.path}: ')}")
            except ValueError as exc:
                refuse(f"{value!r}: {exc}")


#: A vector axis' scalar summary: its column in the tidy table and the x axis of its figure.
SUMMARIES = {
    "attitude": ("attitude_angle_deg", "initial rotation angle from the world frame [deg]"),
    "rate": ("rate_norm", "|ω0| [rad/s]"),
    "rate_deg": ("rate_deg_norm", "|ω0| [deg/s]"),
    "rate_direction": ("rate_tilt_deg", "angle between ω0 and the body z axis [deg]"),
    "dipole": ("dipole_norm", "|m| [A m²]"),
    "inertia": ("inertia_ratio", "I₃ / I₁, third over first principal moment"),
}


def axis_summary(name: str, value) -> tuple[str, float]:
    """``(column, value)``: the scalar that stands for a vector axis' value in tables and figures."""
    v = np.asarray(value, dtype=float)
    big = np.max(np.abs(v))
    if name in ("attitude", "rate_direction") and big > 0:
        v = v / big  # a norm of 1e-320 or 1e308 squared under- or overflows
    if name == "attitude":
        return SUMMARIES[name][0], float(np.degrees(2 * np.arccos(min(1.0, abs(v[0]) / np.linalg.norm(v)))))
    if name == "rate_direction":
        return SUMMARIES[name][0], float(np.degrees(np.arccos(np.clip(v[2] / np.linalg.norm(v), -1, 1))))
    if name == "inertia":
        return SUMMARIES[name][0], float(v[2] / v[0])
    return SUMMARIES[name][0], float(np.linalg.norm(v))


def kinds_label(kinds: list) -> str:
    """A ``torques`` axis value as one label: the kinds kept, joined by ``+``; ``none`` for torque free."""
    return "+".join(kinds) or "none"


_COMPONENTS = {"attitude": ("w", "x", "y", "z"), "inertia": ("1", "2", "3")}


def flat_params(params: dict) -> dict:
    """A cell's parameters as scalar columns: a vector axis gives one column per component (``rate_x``,
    ``attitude_w``, ``inertia_1``) and a summary (:func:`xcheck.sweep.spec.axis_summary`), a model its file name."""
    out = {}
    for name, value in params.items():
        if AXES.get(name) is not None and AXES[name].kind == "kinds":  # torque kinds kept: one text column
            out[name] = kinds_label(value)
        elif isinstance(value, list):
            for comp, v in zip(_COMPONENTS.get(name, ("x", "y", "z")), value):
                out[f"{name}_{comp}"] = v
            label, summary = axis_summary(name, value)
            out[label] = summary
        elif name == "model":
            out[name] = Path(value).name
        else:
            out[name] = value
    return out


def _cell(params: dict) -> dict:
    return {"id": cell_id(params), "params": params}


def apply_cell(base: Scenario, params: dict) -> Scenario:
    """The scenario of one cell: ``base`` with the cell's parameters in place (a new :class:`Scenario`; the
    base is not changed), each axis by its declaration (:data:`AXES`), in their order; a field's own keys
    (``field.<key>``) after the field model, where the cell's model has that key."""
    import dataclasses
    from functools import lru_cache

    from ..fields import FIELDS
    from ..models import load_body

    sc = dataclasses.replace(base, torque=copy_torque(base.torque))
    body = lru_cache(maxsize=1)(lambda: load_body(sc.model))  # the cell's model (after a model axis)
    for name, axis in AXES.items():
        if name in params and axis.apply is not None:
            axis.apply(sc, params[name], body)
        if name == "field":
            for key, value in ((k.removeprefix("field."), v) for k, v in params.items() if k.startswith("field.")):
                term = magnetic_term(sc.torque)
                if term is not None and key in FIELDS[term["field"]].keys:  # a key the cell's field model has
                    term[key] = value
    return sc


def _read_axis(path: Path, name: str, table, base: Scenario, combine: str) -> Axis:
    from ..fields import FIELDS

    def refuse(message):
        raise SweepError(f"{path}: [axes.{name}] {message}")

    if not isinstance(table, dict):
        refuse("expected a table (values = [...], or range = [low, high], ...)")
    ax = _Reader(path, table, f"axes.{name}")
    if name.startswith("field."):
        key = name.removeprefix("field.")
        term = magnetic_term(base.torque)
        if term is None:
            refuse(f"the base scenario {base.name} has no magnetic field to vary")
        declared = FIELDS[term["field"]].keys
        if key not in declared:
            refuse(f"the base's field model {term['field']!r} has no key {key!r} (it has: "
                   f"{', '.join(declared) or 'none'})")
        kind = declared[key].kind  # the axis kinds include the field keys' kinds
    elif name in AXES:
        kind = AXES[name].kind
        if name in MAGNETIC_AXES and magnetic_term(base.torque) is None:
            refuse(f"the base scenario {base.name} has no magnetic torque: nothing for {name!r} to vary")
    else:
        refuse(f"unknown axis (expected one of: {', '.join(AXES)}, or field.<key> of the base's field model)")
    axis = Axis(name=name, kind=kind)
    given = [k for k in ("values", "range", "random", "mean") if ax.has(k)]
    if len(given) != 1:
        ax.fail("values", "give exactly one of values = [...], range = [low, high], random = \"...\", or (with "
                          "combine = \"sample\") mean and std")
    if ax.has("random"):
        axis.random = ax.get("random", "string")
        if RANDOM.get(name) != axis.random:
            ax.fail("random", f"only {', '.join(f'{a} (random = {r!r})' for a, r in RANDOM.items())} are random")
        if combine == "product":
            axis.count = ax.get("count", "integer", required=True)
            if axis.count < 1:
                ax.fail("count", f"expected a positive number of draws, got {axis.count}")
    elif ax.has("values"):
        raw = ax.get("values", "list")
        if not raw:
            ax.fail("values", "an empty list: give at least one value")
        axis.values = [_value(ax, "values", kind, v, path) for v in raw]
    elif ax.has("range"):
        if kind not in ("number", "positive"):
            ax.fail("range", f"a range needs a numeric axis; {name!r} takes {kind} values: use values = [...]")
        rng = ax.get("range", "numbers")
        if len(rng) != 2 or not rng[0] < rng[1]:
            ax.fail("range", f"expected [low, high] with low < high, got {rng}")
        axis.low, axis.high = float(rng[0]), float(rng[1])
        if kind == "positive" and axis.low <= 0:
            ax.fail("range", f"{name} is positive: the range must start above 0, got {rng}")
        if combine == "product":
            axis.num = ax.get("num", "integer", required=True)
            if axis.num < 1:
                ax.fail("num", f"expected a positive number of points, got {axis.num}")
            axis.spacing = ax.get("spacing", "string", "linear")
            if axis.spacing not in ("linear", "log"):
                ax.fail("spacing", f"expected 'linear' or 'log', got {axis.spacing!r}")
            if axis.spacing == "log" and axis.low <= 0:
                ax.fail("spacing", "log spacing needs a range above 0")
        else:
            axis.distribution = ax.get("distribution", "string", "uniform")
            if axis.distribution not in ("uniform", "log-uniform"):
                ax.fail("distribution", f"with a range: 'uniform' or 'log-uniform', got {axis.distribution!r}")
            if axis.distribution == "log-uniform" and axis.low <= 0:
                ax.fail("distribution", "log-uniform needs a range above 0")
    else:  # mean and std: a normal distribution, sample mode only
        if combine != "sample":
            ax.fail("mean", "mean and std describe a distribution: only with combine = \"sample\"")
        axis.distribution = ax.get("distribution", "string", "normal")
        if axis.distribution != "normal":
            ax.fail("distribution", f"with mean and std: 'normal', got {axis.distribution!r}")
        axis.mean = ax.get("mean", "number")
        axis.std = ax.get("std", "number", required=True)
        if kind != "number" or not axis.std > 0:
            ax.fail("std", "a normal axis is a plain number axis with std > 0 (a positive quantity: use a "
                           "log-uniform range)")
    ax.finish()
    return axis


def _value(ax: _Reader, key: str, kind: str, v, path: Path):
    """One explicit value of an axis, checked for its kind."""
    def bad(expected):
        ax.fail(key, f"expected {expected}, got {v!r}")

    if kind in ("number", "positive"):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
            bad("finite numbers")
        if kind == "positive" and v <= 0:
            bad("positive numbers")
        return float(v)
    if kind in ("vector3", "positive3", "quaternion"):
        n = 4 if kind == "quaternion" else 3
        if (not isinstance(v, list) or len(v) != n
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x) for x in v)):
            bad(f"lists of {n} finite numbers")
        if kind == "positive3" and min(v) <= 0:
            bad("three positive principal moments")
        if kind == "quaternion":
            norm = float(np.linalg.norm(v))
            if abs(norm - 1) > 1e-6:
                bad("unit quaternions [w, x, y, z] (norm 1 within 1e-6)")
        return [float(x) for x in v]
    if kind == "kinds":  # torque kinds, a list each
        from ..torque_terms import TORQUE_KINDS

        if not isinstance(v, list) or not all(isinstance(x, str) and x in TORQUE_KINDS for x in v):
            bad(f"lists of torque kinds ({', '.join(TORQUE_KINDS)})")
        return list(v)
    if kind == "path":
        if not isinstance(v, str):
            bad("file names")
        p = (path.parent / v).resolve()
        if not p.is_file():
            ax.fail(key, f"no such file {v!r} (resolved to {p})")
        return str(p)
    if kind == "string":
        if not isinstance(v, str):
            bad("strings")
        if ax.section == "axes.field":
            from ..fields import FIELDS

            if v not in FIELDS:
                ax.fail(key, f"unknown field model {v!r}; expected one of {', '.join(FIELDS)}")
        return v
    raise AssertionError(kind)
