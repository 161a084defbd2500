"""How a trajectory file states its attitude and rates (:class:`Convention`), read from a scenario's
``[[trajectory]]`` table or a file's sidecar declaration, and the conversion of its columns to xcheck's convention
(:func:`to_world`): ``q`` ``[w, x, y, z]`` body -> world, the body rate relative to inertial space in body components,
rad and rad/s.

The declaration (every key but ``file`` optional; the defaults read the CSV ``xcheck run --csv`` writes)::

    file = "sim.csv"                  # relative to the scenario (or the declaration's) folder
    name = "SIM 01"                   # the file's row in the report (default: the file's stem)
    time = "t_s"                      # the time column (default: the first of t_s, t, time the header has)
    time_unit = "s"                   # "s" or "ms"
    attitude = "quaternion"           # "quaternion", "dcm" (9 columns, row by row) or "euler"
    columns = ["qw", "qx", "qy", "qz"]  # the attitude's columns, in the order the convention reads them
    scalar = "first"                  # a quaternion's scalar part: "first" or "last" of `columns`
    direction = "body-to-frame"       # what the attitude maps: "body-to-frame" or "frame-to-body"
    frame = "world"                   # the frame it is relative to: "world" (inertial) or "ned" (the scenario's [earth])
    sequence = "321"                  # Euler angles: intrinsic sequence (xcheck.rotations: "321" is yaw, pitch, roll)
    angle_unit = "rad"                # "rad" or "deg"
    rates = ["wx_rad_s", "wy_rad_s", "wz_rad_s"]  # the body rate's columns (default: these if present)
    rates_frame = "body"              # the components: "body" or "frame"
    rates_unit = "rad/s"              # "rad/s" or "deg/s"
    rates_relative_to = "inertial"    # the body's rate relative to "inertial" space or to the "frame"
    normalise = false                 # quaternions (or matrices) off the unit sphere by more than 1e-6: refused, or
                                      # normalised (orthonormalised) and said
    tolerance = 1e-6                  # the largest attitude error [rad] of a verdict PASSED (default: the scenario's
                                      # [checks] final_error)
    source = "..."                    # where the file comes from (cited in the report)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .. import rotations as rot
from ..trajectory import continuous_quaternions
from .earth import WGS84_RATE, Earth, ned_frames

__all__ = ["Convention", "read_convention", "read_earth", "MAX_FILE_BYTES", "to_world", "KEYS", "TIME_COLUMNS", "XCHECK_RATES", "columns_of",
           "Converted", "declared_layout", "layout_of", "LAYOUT_KEYS"]

#: The keys of a declaration, with what each may be (None: free text or numbers, checked by the reader).
KEYS = {"file": None, "name": None, "time": None, "time_unit": ("s", "ms"), "attitude": ("quaternion", "dcm", "euler"),
        "columns": None, "scalar": ("first", "last"), "direction": ("body-to-frame", "frame-to-body"),
        "frame": ("world", "ned"), "sequence": rot.EULER_SEQUENCES, "angle_unit": ("rad", "deg"), "rates": None,
        "rates_frame": ("body", "frame"), "rates_unit": ("rad/s", "deg/s"),
        "rates_relative_to": ("inertial", "frame"), "normalise": None, "tolerance": None, "rate_tolerance": None,
        "source": None}
#: The time columns looked for when the declaration names none.
TIME_COLUMNS = ("t_s", "t", "time")
#: The rate columns of xcheck's own CSV (read when present and the declaration names none).
XCHECK_RATES = ("wx_rad_s", "wy_rad_s", "wz_rad_s")
_DEFAULT_COLUMNS = {("quaternion", "first"): ("qw", "qx", "qy", "qz"), ("quaternion", "last"): ("qx", "qy", "qz", "qw"),
                    ("dcm", "first"): tuple(f"R{i}{j}" for i in "123" for j in "123"),
                    ("euler", "first"): ("euler1_rad", "euler2_rad", "euler3_rad")}
_WIDTH = {"quaternion": 4, "dcm": 9, "euler": 3}


@dataclass(frozen=True)
class Convention:
    """A trajectory file and how to read it (the module's docstring lists the keys and defaults)."""

    file: Path
    name: str = ""
    time: str | None = None
    time_unit: str = "s"
    attitude: str = "quaternion"
    columns: tuple | None = None
    scalar: str = "first"
    direction: str = "body-to-frame"
    frame: str = "world"
    sequence: str = "321"
    angle_unit: str = "rad"
    rates: tuple | None = None
    rates_frame: str = "body"
    rates_unit: str = "rad/s"
    rates_relative_to: str = "inertial"
    normalise: bool = False
    tolerance: float | None = None
    rate_tolerance: float | None = None
    source: str = ""

    @property
    def attitude_columns(self) -> tuple:
        if self.columns is not None:
            return self.columns
        return _DEFAULT_COLUMNS[(self.attitude, self.scalar if self.attitude == "quaternion" else "first")]

    def describe(self, rates_read=None) -> str:
        """The convention in words, for the report (``quaternion [w x y z] body -> world``); ``rates_read``: the
        rate columns the file was read with (its default ones where none are declared; issue 64: "no rates" was
        said of a file whose default rates were read)."""
        what = {"quaternion": f"quaternion, scalar {self.scalar}", "dcm": "direction-cosine matrix (row by row)",
                "euler": f"Euler angles {self.sequence} [{self.angle_unit}]"}[self.attitude]
        where = "world" if self.frame == "world" else "local NED"
        arrow = f"body -> {where}" if self.direction == "body-to-frame" else f"{where} -> body"
        rates = ("no rates" if not (rates_read or self.rates) else
                 f"rates in {self.rates_frame} components [{self.rates_unit}], relative to "
                 f"{'inertial space' if self.rates_relative_to == 'inertial' else 'the ' + where + ' frame'}")
        return f"{what}, {arrow}; {rates}"


#: The largest trajectory file read [bytes]: it is read a block of lines at a time, keeping only the columns it uses.
MAX_FILE_BYTES = 4 * 2**30

#: The keys of ``[earth]``.
EARTH_KEYS = ("latitude_deg", "longitude_deg", "height_m", "velocity_ned", "rotation_rate", "motion")


def read_earth(reader) -> Earth:
    """A scenario's ``[earth]``: where the body starts over a rotating Earth (geodetic ``latitude_deg``,
    ``longitude_deg``, ``height_m`` above the WGS-84 ellipsoid), its ``velocity_ned`` relative to the Earth [m/s],
    the ``rotation_rate`` [rad/s, default WGS-84's] and its ``motion``: ``"fall"`` or ``"fixed"``."""
    for key in reader.table:
        if key not in EARTH_KEYS:
            reader.fail(key, f"unknown key (expected one of: {', '.join(EARTH_KEYS)})")
    lat = reader.get("latitude_deg", "number", 0.0)
    if not -90.0 <= lat <= 90.0:
        reader.fail("latitude_deg", f"expected a latitude within [-90, 90] degrees, got {lat:g}")
    lon = reader.get("longitude_deg", "number", 0.0)
    height = reader.get("height_m", "number", 0.0)
    if not -1e4 <= height <= 1e6:
        reader.fail("height_m", f"expected a height within [-10 km, 1000 km] of the ellipsoid, got {height:g} m")
    velocity = tuple(reader.get("velocity_ned", ("vector", 3), np.zeros(3)).tolist())
    rate = reader.get("rotation_rate", "number", WGS84_RATE)
    if abs(rate) > 1e-2:
        reader.fail("rotation_rate", f"expected the Earth's rotation rate in rad/s (WGS-84: {WGS84_RATE:g}), got "
                                     f"{rate:g}")
    motion = reader.get("motion", "string", "fall")
    if motion not in ("fall", "fixed"):
        reader.fail("motion", f"expected 'fall' or 'fixed', got {motion!r}")
    reader.finish()
    return Earth(latitude=math.radians(lat), longitude=math.radians(lon), height=height, velocity_ned=velocity,
                 rate=rate, motion=motion)


def read_convention(reader, *, earth: Earth | None) -> Convention:
    """A :class:`Convention` from a declaration's table (``reader``: the scenario's typed reader of that table, whose
    ``fail(key, message)`` names the file and key; the file relative to the reader's); ``frame = "ned"`` needs
    ``earth`` (the scenario's ``[earth]``)."""
    values = {}
    for key in reader.table:
        if key not in KEYS:
            reader.fail(key, f"unknown key (expected one of: {', '.join(KEYS)})")
    values["file"] = reader.path_("file", required=True, limit=MAX_FILE_BYTES)
    for key in ("name", "time", "source"):
        if reader.has(key):
            values[key] = reader.get(key, "string")
    for key, allowed in KEYS.items():
        if allowed is not None and reader.has(key):
            value = reader.get(key, "string")
            if value not in allowed:
                reader.fail(key, f"expected one of {', '.join(map(repr, allowed))}, got {value!r}")
            values[key] = value
    for key in ("columns", "rates"):
        if reader.has(key):
            values[key] = tuple(reader.get(key, "strings"))
    if reader.has("normalise"):
        values["normalise"] = reader.get("normalise", "bool")
    for key in ("tolerance", "rate_tolerance"):
        if reader.has(key):
            values[key] = reader.positive(key)
    conv = Convention(**values)
    width = _WIDTH[conv.attitude]
    if conv.columns is not None and len(conv.columns) != width:
        reader.fail("columns", f"a {conv.attitude} has {width} columns, got {len(conv.columns)}: {list(conv.columns)}")
    if conv.rates is not None and len(conv.rates) != 3:
        reader.fail("rates", f"expected the 3 columns of the body rate, got {len(conv.rates)}")
    if conv.attitude != "quaternion" and reader.has("scalar"):
        reader.fail("scalar", f"only a quaternion has a scalar part; this file's attitude is {conv.attitude}")
    if conv.attitude != "euler" and reader.has("sequence"):
        reader.fail("sequence", f"only Euler angles have a sequence; this file's attitude is {conv.attitude}")
    if conv.frame == "ned" and earth is None:
        reader.fail("frame", "'ned' is the local North-East-Down frame of the scenario's [earth] table, which this "
                             "scenario does not have")
    if not conv.name:
        conv = replace(conv, name=conv.file.stem)
    reader.finish()
    return conv


def columns_of(conv: Convention, header: list[str], where: str) -> tuple[str, tuple, tuple | None]:
    """The time, attitude and rate columns ``conv`` reads from a file with ``header``; a ValueError naming the file
    (``where``), the declaration's key and the columns the file has when one is missing."""
    have = set(header)
    time = conv.time or next((c for c in TIME_COLUMNS if c in have), None)
    shown = ", ".join(h if len(h) <= 40 else h[:37] + "..." for h in header[:12]) + (", ..." if len(header) > 12 else "")
    if time is None or time not in have:
        raise ValueError(f"{where}: no time column {conv.time or ' or '.join(TIME_COLUMNS)!r} (time); the header has: "
                         f"{shown}")
    missing = [c for c in conv.attitude_columns if c not in have]
    if missing:
        raise ValueError(f"{where}: the attitude's column(s) {missing} (columns) are not in the header, which has: "
                         f"{shown}")
    rates = conv.rates
    if rates is None and all(c in have for c in XCHECK_RATES):
        rates = XCHECK_RATES
    if rates is not None and any(c not in have for c in rates):
        raise ValueError(f"{where}: the rates' column(s) {[c for c in rates if c not in have]} (rates) are not in the "
                         f"header, which has: {shown}")
    return time, tuple(conv.attitude_columns), rates


#: What a declaration says about reading a file, beside which file it is and how it is judged: two declarations that
#: agree on these read a file alike.
LAYOUT_KEYS = ("time", "time_unit", "attitude", "columns", "scalar", "direction", "frame", "sequence", "angle_unit",
               "rates", "rates_frame", "rates_unit", "rates_relative_to", "normalise")


def declared_layout(header: list[str], declarations) -> list:
    """The ``declarations`` (a scenario's ``[[trajectory]]`` tables) that read a file with ``header``: each that
    names its attitude's columns, all of which the header has, with its time and rates (where it has them). A declaration
    that leaves its columns to the defaults (xcheck's own CSV) matches none: the defaults are read without it."""
    def reads(c) -> bool:
        try:
            columns_of(c, header, "")
        except ValueError:
            return False
        return True

    return [c for c in declarations if c.columns is not None and reads(c)]


def layout_of(conv: Convention) -> tuple:
    """``conv``'s reading of a file (:data:`LAYOUT_KEYS`), to tell declarations that read alike."""
    return tuple(getattr(conv, k) for k in LAYOUT_KEYS)


@dataclass
class Converted:
    """A file's samples in xcheck's convention: times [s], ``q`` body -> world, the body rate relative to inertial
    space in body components [rad/s] (None without rates), and notes on what was done (a normalisation)."""

    t: np.ndarray
    q: np.ndarray
    omega: np.ndarray | None
    notes: list = field(default_factory=list)


#: Quaternions and matrices further than this from unit norm (orthonormality) are refused unless ``normalise``.
UNIT_TOLERANCE = 1e-6
#: Euler angles larger than this [rad] are refused: a double keeps no digit of a turn past about 1e15 rad, and no
#: simulator's angle wraps that far (issue 64: a file's numbers are bounded where they are read).
MAX_ANGLE = 1e6


def _norms(X: np.ndarray) -> np.ndarray:
    """The Euclidean norm of each row of ``X``, computed without overflow (rows of 1e300)."""
    scale = np.max(np.abs(X), axis=1) if X.size else np.zeros(len(X))
    safe = np.where(scale > 0, scale, 1.0)
    return scale * np.sqrt(np.sum((X / safe[:, None]) ** 2, axis=1))


def _bounded(conv: Convention, A: np.ndarray, W, where: str, row) -> None:
    """The gate of a file's numbers before they are converted (issue 64): a matrix that cannot be made a rotation
    (zero, singular or a reflection, even to normalise: no rotation is nearest to it), Euler angles beyond
    :data:`MAX_ANGLE`, and body rates beyond :data:`~xcheck.body.MAX_RATE` (after the unit) are refused, naming the
    file, the line, the columns and the bound: a ValueError. (A quaternion of norm 0 is refused where
    :func:`to_world` forms its norms.)"""
    from ..body import MAX_RATE

    if conv.attitude == "dcm":
        R = A.reshape(-1, 3, 3)
        scale = np.max(np.abs(A), axis=1) if A.size else np.zeros(0)
        det = np.linalg.det(R / np.where(scale > 0, scale, 1.0)[:, None, None]) if len(R) else np.zeros(0)
        bad = np.flatnonzero(~((scale > 0) & (det > 1e-9)))
        if bad.size:
            k = int(bad[0])
            what = "is zero" if scale[k] == 0 else "is a reflection (determinant < 0)" if det[k] < 0 else "is singular"
            raise ValueError(f"{where}, {row(k)}: the matrix ({', '.join(conv.attitude_columns)}) {what}: no rotation "
                             "is nearest to it, orthonormalised or not")
    elif conv.attitude == "euler":
        limit = np.degrees(MAX_ANGLE) if conv.angle_unit == "deg" else MAX_ANGLE
        bad = np.flatnonzero(np.max(np.abs(A), axis=1) > limit) if A.size else np.zeros(0, int)
        if bad.size:
            k = int(bad[0])
            raise ValueError(f"{where}, {row(k)}: the Euler angles {A[k].tolist()} ({', '.join(conv.attitude_columns)})"
                             f" exceed {limit:.3g} {conv.angle_unit}: expected angles of at most that size")
    if W is not None:
        W = np.asarray(W, dtype=float)
        limit = np.degrees(MAX_RATE) if conv.rates_unit == "deg/s" else MAX_RATE
        bad = np.flatnonzero(_norms(W) > limit) if W.size else np.zeros(0, int)
        if bad.size:
            k = int(bad[0])
            columns = ", ".join(conv.rates or XCHECK_RATES)
            raise ValueError(f"{where}, {row(k)}: the body rate {W[k].tolist()} ({columns}) "
                             f"exceeds {limit:.3g} {conv.rates_unit} in magnitude: expected at most that (xcheck's "
                             "bound on a rate)")


def to_world(conv: Convention, t, A, W, *, earth: Earth | None, where: str = "", check: bool = True,
             lines=None) -> Converted:
    """Samples of a file (times ``t``, attitude columns ``A`` in ``conv``'s order, rate columns ``W`` or None) in
    xcheck's convention. ``check``: a quaternion or matrix off the unit sphere by more than :data:`UNIT_TOLERANCE`
    is refused (a ValueError naming ``where``, the row as the file's line ``lines[k]`` when given, and by how much)
    unless ``conv.normalise``; the detective converts with ``check=False``."""
    t = np.asarray(t, dtype=float) * (1e-3 if conv.time_unit == "ms" else 1.0)
    A = np.asarray(A, dtype=float)
    notes = []

    def row(k: int) -> str:
        return f"line {lines[k]}" if lines is not None else f"row {k}"

    if check:
        _bounded(conv, A, W, where, row)
    if conv.attitude == "quaternion":
        q = A if conv.scalar == "first" else A[:, [3, 0, 1, 2]]
        norm = _norms(q)
        zero = np.flatnonzero(~(norm > 0)) if check else ()
        if len(zero):
            k = int(zero[0])
            raise ValueError(f"{where}, {row(k)}: the quaternion {A[k].tolist()} ({', '.join(conv.attitude_columns)}) "
                             "has norm 0: no rotation, normalised or not")
        off = np.abs(norm - 1.0)
        k = int(np.argmax(off)) if len(off) else 0
        if check and len(off) and off[k] > UNIT_TOLERANCE:
            if not conv.normalise:
                raise ValueError(f"{where}, {row(k)}: the quaternion {A[k].tolist()} has norm {norm[k]:.9g} "
                                 f"(off unit by {off[k]:.2g}, beyond {UNIT_TOLERANCE:g}): is it a quaternion? Declare "
                                 "normalise = true to have it normalised")
            notes.append(f"quaternions normalised (their norms were off unit by up to {off[k]:.2g}, {row(k)})")
        q = q / norm[:, None]
    elif conv.attitude == "dcm":
        R = A.reshape(-1, 3, 3)
        gram = np.abs(np.einsum("nki,nkj->nij", R, R) - np.eye(3)).max(axis=(1, 2)) if len(R) else np.zeros(0)
        k = int(np.argmax(gram)) if len(gram) else 0
        if check and len(gram) and gram[k] > UNIT_TOLERANCE:
            if not conv.normalise:
                raise ValueError(f"{where}, {row(k)}: the matrix is not a rotation (|R^T R - I| = {gram[k]:.2g}, "
                                 f"beyond {UNIT_TOLERANCE:g}): declare normalise = true to have it orthonormalised")
            notes.append(f"matrices orthonormalised (|R^T R - I| up to {gram[k]:.2g}, {row(k)})")
        if conv.normalise or not check:
            u, _, vt = np.linalg.svd(R)
            R = u @ vt
        q = rot.dcm_to_quat(R)
    else:
        angles = np.radians(A) if conv.angle_unit == "deg" else A
        q = rot.euler_to_quat(angles, conv.sequence)
    if conv.direction == "frame-to-body":
        q = rot.quat_conj(q)
    omega = None
    if W is not None:
        omega = np.radians(np.asarray(W, dtype=float)) if conv.rates_unit == "deg/s" else np.asarray(W, dtype=float)
        if conv.rates_frame == "frame":  # frame components -> body components
            omega = rot.quat_to_dcm(rot.quat_conj(q)) @ omega[..., None]
            omega = omega[..., 0]
    if conv.frame == "ned":
        q_frame, w_frame = ned_frames(earth, t)
        if omega is not None and conv.rates_relative_to == "frame":  # + the frame's own rate, in body components
            omega = omega + (rot.quat_to_dcm(rot.quat_conj(q)) @ w_frame[..., None])[..., 0]
        q = rot.quat_mul(q_frame, q)
    return Converted(t=t, q=continuous_quaternions(q), omega=omega, notes=notes)
