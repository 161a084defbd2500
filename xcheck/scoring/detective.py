"""The convention detective: when a trajectory file is far from the reference, read it again with each of the usual
mistakes undone — a quaternion's scalar last instead of first, the conjugate rotation (a transposed matrix), another
Euler sequence or the angles in reverse order, degrees for radians, a frame that does not turn (or turns the other
way, or stays over the start point), rates in the frame's components, in deg/s, relative to the frame, and times one
sample off — and say which, if any, makes the error vanish. A finding, not a fix: the file's verdict stays on the
file as given.

Each reading is tried on up to :data:`SAMPLES` rows spread over the file (all of a shorter one), against the same
reference values.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .. import rotations as rot
from .convention import Convention, to_world
from .earth import Earth

__all__ = ["Finding", "investigate", "SAMPLES", "EXPLAINS"]

#: Rows tried per reading.
SAMPLES = 20001
#: A reading explains the error when it leaves at most this fraction of it (and passes the file's tolerance).
EXPLAINS = 1e-2


@dataclass
class Finding:
    """A reading of the file that differs from its declaration in ``change`` (words: "read scalar-last"), and its
    largest attitude error [rad] and rate error [rad/s] against the reference (None: the file has no rates)."""

    change: str
    attitude_error: float
    rate_error: float | None
    #: what the reading changes: "attitude" (judged on the attitude error) or "rates" (on the rate error)
    judged: str = "attitude"

    @property
    def error(self) -> float:
        """The error the reading is judged on."""
        return self.attitude_error if self.judged == "attitude" else self.rate_error

    def to_json(self) -> dict:
        return {"change": self.change, "judged": self.judged, "max_attitude_error": self.attitude_error,
                "max_rate_error": self.rate_error}


def _readings(conv: Convention, earth: Earth | None, has_rates: bool):
    """``(words, reading, judged on)``: every reading tried, one to four choices changed; a reading is a convention,
    or ``(convention, earth, column order or None)``."""
    out = []
    flip = {"direction": {"body-to-frame": "frame-to-body", "frame-to-body": "body-to-frame"},
            "scalar": {"first": "last", "last": "first"}, "angle_unit": {"rad": "deg", "deg": "rad"},
            "rates_frame": {"body": "frame", "frame": "body"}, "rates_unit": {"rad/s": "deg/s", "deg/s": "rad/s"},
            "rates_relative_to": {"inertial": "frame", "frame": "inertial"}}
    conj = "as the conjugate rotation (frame -> body)" if conv.direction == "body-to-frame" else \
        "as the rotation body -> frame"
    if conv.attitude == "quaternion":
        scalar = f"scalar-{flip['scalar'][conv.scalar]}"
        out += [(f"read {scalar}", replace(conv, scalar=flip["scalar"][conv.scalar]), "attitude"),
                (f"read {conj}", replace(conv, direction=flip["direction"][conv.direction]), "attitude"),
                (f"read {scalar} and {conj}", replace(conv, scalar=flip["scalar"][conv.scalar],
                                                      direction=flip["direction"][conv.direction]), "attitude")]
    elif conv.attitude == "dcm":
        out += [("read transposed (the matrix maps the other way)",
                 replace(conv, direction=flip["direction"][conv.direction]), "attitude")]
    else:
        cols = conv.attitude_columns
        for seq in rot.EULER_SEQUENCES:
            for order in (cols, cols[::-1]):
                for direction in ("body-to-frame", "frame-to-body"):
                    for unit in ("rad", "deg"):
                        if (seq, order, direction, unit) == (conv.sequence, cols, conv.direction, conv.angle_unit):
                            continue
                        words = []
                        if seq != conv.sequence:
                            words.append(f"as the sequence {seq}")
                        if order != cols:
                            words.append("with the angle columns in reverse order")
                        if direction != conv.direction:
                            words.append(conj)
                        if unit != conv.angle_unit:
                            words.append(f"with the angles in {'degrees' if unit == 'deg' else 'radians'}")
                        reading = replace(conv, sequence=seq, direction=direction, angle_unit=unit)
                        out.append(("read " + ", ".join(words),
                                    (reading, earth, None if order == cols else [2, 1, 0]), "attitude"))
    if conv.frame == "world" and earth is not None:
        out.append(("read relative to the local NED frame of the scenario's [earth]", replace(conv, frame="ned"),
                    "attitude"))
    if conv.frame == "ned" and earth is not None:
        out += [("if its frame were inertial (not turning with the Earth)", replace(conv, frame="world"), "attitude"),
                ("if the Earth turned the other way", (conv, replace(earth, rate=-earth.rate), None), "attitude"),
                ("if its frame stayed over the start point (the fall left out)",
                 (conv, replace(earth, motion="fixed"), None), "attitude")]
    if has_rates:
        for key in ("rates_frame", "rates_unit") + (("rates_relative_to",) if conv.frame == "ned" else ()):
            words = {"rates_frame": "with the rates in {} components", "rates_unit": "with the rates in {}",
                     "rates_relative_to": "with the rates relative to {}"}[key]
            value = flip[key][getattr(conv, key)]
            shown = {"inertial": "inertial space", "frame": "the frame"}.get(value, value)
            out.append(("read " + words.format(shown), replace(conv, **{key: value}), "rates"))
    return out


def investigate(conv: Convention, samples, reference, *, earth: Earth | None) -> tuple[list, int]:
    """Every reading of :func:`_readings` and the two time offsets, on a spread of the rows of ``samples``
    (:class:`~xcheck.scoring.reader.Samples`) against ``reference(t) -> (q, omega, mask)``; returns the findings
    (sorted, best first) and how many readings were tried."""
    n = len(samples.t)
    rows = np.unique(np.linspace(0, n - 1, min(n, SAMPLES)).astype(np.int64))
    t, A = samples.t[rows], samples.attitude[rows]
    W = samples.rates[rows] if samples.rates is not None else None
    base = to_world(conv, t, A, W, earth=earth, check=False)
    q_ref, w_ref, mask = reference(base.t)
    findings = []
    tried = 0
    for words, reading, judged in _readings(conv, earth, W is not None):
        alt_conv, alt_earth, order = reading if isinstance(reading, tuple) else (reading, earth, None)
        try:
            alt = to_world(alt_conv, t, A if order is None else A[:, order], W, earth=alt_earth, check=False)
        except (ValueError, FloatingPointError):
            continue
        tried += 1
        findings.append(_finding(words, alt, q_ref, w_ref, mask, judged))
    times = samples.t * (1e-3 if conv.time_unit == "ms" else 1.0)
    for shift, words in ((1, "if each row were the state one sample later than its time"),
                         (-1, "if each row were the state one sample earlier than its time")):
        moved = np.clip(rows + shift, 0, n - 1)
        keep = (rows + shift >= 0) & (rows + shift <= n - 1)
        q2, w2, m2 = reference(times[moved])
        tried += 1
        findings.append(_finding(words, base, q2, w2, m2 & keep, "attitude"))
    findings.sort(key=lambda f: (f.judged, f.error))
    return findings, tried


def _finding(words, conv_world, q_ref, w_ref, mask, judged) -> Finding:
    att = float(np.max(rot.attitude_error(conv_world.q[mask], q_ref[mask]))) if mask.any() else float("inf")
    rate = None
    if conv_world.omega is not None and mask.any():
        rate = float(np.max(np.linalg.norm(conv_world.omega[mask] - w_ref[mask], axis=1)))
    return Finding(change=words, attitude_error=att, rate_error=rate, judged=judged)
