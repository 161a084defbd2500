"""The three invariants a user asks about, kept apart and signed (issue 60): the **energy** (kinetic, and a top's
potential), the **magnitude of the angular momentum** |L| (or, under a torque that keeps only one component of L, that
component: a top's about the vertical) and the **direction of L** (the angle it has turned from its start).

A signed change is relative: ``E(t)/E(0) - 1`` (relative to ``|T0| + |V0|`` where a potential enters the energy),
``|L(t)|/|L(0)| - 1`` (or ``(L(t) - L(0))·ĝ / |L(0)|``): **positive where the method gains, negative where it damps**.
The direction's change is an angle [rad], never negative. A run's number for each is its *largest* change over the run
with its sign (:func:`largest_change`): a method that gains steadily reaches it at the end.

Each comes with its law over the run (:func:`drift_law`: round-off, bounded, a growth ∝ t or t^q, or not kept at all),
told with its direction (:func:`law_text`: "gains ∝ t", "damps ∝ t^1.52", "bounded oscillation").

Core: numpy only. World momentum ``L = R(q) (I ω + h)`` with ``R`` body -> world, ``ω`` body rates, ``h`` a gyrostat's
wheels' momentum in body components."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import rotations as rot

__all__ = ["InvariantSeries", "invariant_series", "largest_change", "drift_law", "law_text", "change_text", "law_samples",
           "NOT_KEPT", "DRIFT_ROUND_OFF", "CHANGE_KEYS", "LAW_KEYS", "RUN_KEYS", "LABELS"]

#: A drift at least this large (half the energy lost or gained, an angle of 0.5 rad) is "not kept": its running maximum
#: stalls there (MuJoCo's implicitfast damps 95 % of the tumbler's energy over an orbit), which is no bounded error.
NOT_KEPT = 0.5
#: A relative energy drift below this a step is round-off (LGVI's, torque free: 1.6e-16 a step over 1e5 steps).
DRIFT_ROUND_OFF = 1e-15
#: A run's three numbers, by JSON key, and what each is in words.
CHANGE_KEYS = {"energy_change": "energy", "momentum_change": "|L|", "momentum_turn": "L's direction"}
#: Their laws, by JSON key (:meth:`InvariantSeries.laws`).
LAW_KEYS = ("energy_law", "momentum_law", "turn_law")
#: What a run carries of its invariants, and every answer that quotes a run: the three numbers and their laws.
RUN_KEYS = (*CHANGE_KEYS, *LAW_KEYS)
#: What each series is, where a figure or a table names it.
LABELS = {"energy": "ΔE / E0", "energy+V": "ΔE / (|T0| + |V0|), E = T + V", "momentum": "Δ|L| / |L0|",
          "momentum·g": "ΔL·ĝ / |L0|"}


@dataclass
class InvariantSeries:
    """Per sample, the signed relative change of the energy and of |L| (or of the one component of L a torque keeps),
    and the angle [rad] L's direction has turned; each None where the motion does not keep it. ``energy_label`` and
    ``momentum_label`` say which (:data:`LABELS`)."""

    energy: np.ndarray | None
    momentum: np.ndarray | None
    turn: np.ndarray | None
    energy_label: str = LABELS["energy"]
    momentum_label: str = LABELS["momentum"]

    def laws(self, t, steps: int, largest: dict | None = None) -> dict:
        """Each one's law with its direction (:func:`law_text`) over the samples at times ``t`` of a run of ``steps``
        steps (:data:`LAW_KEYS`: None where not kept), and ``energy_exponent``, that of the energy's running maximum
        (None where round-off or not kept). The direction is the sign of the run's largest change: ``largest``
        (:meth:`largest`'s, from every step of the run, where the samples are fewer), else these samples'."""
        largest = largest or self.largest()
        out = {}
        for law_key, change_key, series in zip(LAW_KEYS, CHANGE_KEYS, self.series()):
            law, exponent = (None, None) if series is None else drift_law(t, series, steps)
            out[law_key] = law_text(law, exponent, largest[change_key], angle=change_key == "momentum_turn")
            if law_key == "energy_law":
                out["energy_exponent"] = exponent
        return out

    def series(self) -> tuple:
        """The three series in the order of :data:`CHANGE_KEYS`."""
        return self.energy, self.momentum, self.turn

    def largest(self) -> dict:
        """The run's numbers (:data:`CHANGE_KEYS`): ``energy_change``, ``momentum_change`` (signed) and
        ``momentum_turn`` [rad], each the largest over the run (:func:`largest_change`), None where not kept."""
        return {key: largest_change(series) for key, series in zip(CHANGE_KEYS, self.series())}


def largest_change(series) -> float | None:
    """The value of ``series`` largest in magnitude, with its sign (the first of equals; a NaN, once met, is the
    result, as with ``np.max``); None for None or no samples."""
    if series is None or not len(series):
        return None
    series = np.asarray(series, dtype=float)
    return float(series[np.argmax(np.where(np.isnan(series), np.inf, np.abs(series)))])


def law_samples(n: int, count: int = 48) -> np.ndarray:
    """The indices of a run's ``n + 1`` samples a law is fitted on: the start (what every change is relative to) and
    ``count`` logarithmically spaced from the first step to the last (each once)."""
    return np.unique(np.concatenate([[0], np.rint(np.geomspace(1, max(n, 1), count))]).astype(np.int64))


def invariant_series(inertia, q, omega, torque=None, t=None) -> InvariantSeries:
    """The three invariants along a run under ``torque`` (a :class:`~xcheck.fields.TorqueModel`, or None: torque free,
    all three kept). ``inertia`` (3, 3) [kg m^2], ``q`` (n, 4) body -> world, ``omega`` (n, 3) [rad/s] body frame,
    ``t`` (n,) [s] (a gyrostat's wheels' momentum depends on it). Under a torque: the energy ``T + V`` where it has a
    potential (``torque.potential``), relative to ``|T0| + |V0|``; all of L with the wheels' momentum where the torque
    is internal (``conserves_momentum``); the component along ``torque.momentum_axis()`` where it keeps one (a top's
    vertical: no direction then); else none of them."""
    I = np.asarray(inertia, dtype=float)
    q, omega = np.asarray(q, dtype=float), np.asarray(omega, dtype=float)
    T = 0.5 * np.einsum("...i,ij,...j->...", omega, I, omega)  # metrics.kinetic_energy's
    if torque is None:
        V, h, axis, whole = np.zeros_like(T), None, None, True
    else:
        V = torque.potential(q)
        internal = getattr(torque, "conserves_momentum", False)
        h = torque.internal_momentum(t) if internal and t is not None else None
        axis = None if internal else torque.momentum_axis()
        whole = internal and h is not None
    energy, energy_label = None, LABELS["energy"]
    if V is not None:
        V = np.asarray(V, dtype=float)
        scale = abs(T[0]) + abs(V[0])
        energy = (T + V - T[0] - V[0]) / scale if scale > 0 else np.zeros_like(T)
        if torque is not None:
            energy_label = LABELS["energy+V"]
    if not whole and axis is None:
        return InvariantSeries(energy, None, None, energy_label)
    L = rot.quat_rotate(q, omega @ I.T + (0.0 if h is None else np.asarray(h, dtype=float)))
    x, y, z = L[:, 0], L[:, 1], L[:, 2]  # written out, each sum in one order: metrics' compiled pass does the same
    size = np.sqrt(x * x + y * y + z * z)
    L0 = float(size[0])
    if axis is not None:
        a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
        kept = (L - L[0]) @ a / L0 if L0 > 0 else np.zeros(len(L))
        return InvariantSeries(energy, kept, None, energy_label, LABELS["momentum·g"])
    if L0 == 0:
        return InvariantSeries(energy, np.zeros(len(L)), np.zeros(len(L)), energy_label)
    x0, y0, z0 = L[0]
    cx, cy, cz = y * z0 - z * y0, z * x0 - x * z0, x * y0 - y * x0
    turn = np.arctan2(np.sqrt(cx * cx + cy * cy + cz * cz), x * x0 + y * y0 + z * z0)
    return InvariantSeries(energy, size / L0 - 1.0, turn, energy_label)


def drift_law(t, drift, steps: int | None = None) -> tuple[str | None, float | None]:
    """Whether a drift is bounded or grows: the exponent ``q`` of its running maximum (of ``|drift|``) over windows
    ``[T/2^(k+1), T/2^k]`` (k = 0 ... 5) against their ends; ``"bounded"`` for q < 0.2, ``"secular"`` for q >= 0.8
    (a drift as t), else ``"grows as t^q"``; ``"round-off"`` where it stays below the round-off of the run's
    ``steps`` (:data:`DRIFT_ROUND_OFF` a step, 1e-12 at least; without ``steps``, that of a million): whatever its
    growth, nothing the method does; ``"not kept"`` where it reaches :data:`NOT_KEPT`. (None, None) without
    samples. Unsigned: :func:`law_text` adds the direction."""
    t, drift = np.asarray(t, dtype=float), np.abs(np.asarray(drift, dtype=float))
    if not len(t):
        return None, None
    if np.max(drift) <= max(1e-12, DRIFT_ROUND_OFF * (steps if steps else 1e6)):
        return "round-off", None
    if np.max(drift) >= NOT_KEPT:  # the invariant is gone, or doubled: its running maximum stalls, not bounded
        return "not kept", None
    ends, peaks = [], []
    for k in range(6):
        lo, hi = t[-1] / 2 ** (k + 1), t[-1] / 2 ** k
        window = drift[(t > lo) & (t <= hi)]
        if len(window):
            ends.append(hi)
            peaks.append(max(float(window.max()), 1e-300))
    if len(ends) < 3:
        return None, None
    q = float(np.polyfit(np.log(ends), np.log(peaks), 1)[0])
    return ("bounded" if q < 0.2 else "secular" if q >= 0.8 else f"grows as t^{q:.2f}"), q


def law_text(law: str | None, exponent: float | None, change: float | None, *, angle: bool = False) -> str | None:
    """A law of :func:`drift_law` with its direction, from the run's signed change ``change`` (its largest):
    ``"gains ∝ t"``, ``"damps ∝ t^1.52"``, ``"bounded oscillation"``, ``"round-off"``, ``"damped away (-95 %)"``;
    for an ``angle`` (L's direction, never negative) ``"turns ∝ t"``. None where there is no law."""
    if law is None:
        return None
    if law == "round-off":
        return "round-off"
    if law == "bounded":
        return "bounded oscillation"
    verb = "turns" if angle else "gains" if (change or 0.0) > 0 else "damps"
    if law == "not kept":
        if angle:
            return "not kept" + (f" (turned {change:.2f} rad)" if change is not None else "")
        return ("gained beyond half" if verb == "gains" else "damped away") + (
            f" ({100 * change:+.0f} %)" if change is not None else "")
    if law == "secular":
        return f"{verb} ∝ t"
    return f"{verb} ∝ t^{exponent:.2f}" if exponent is not None else f"{verb} ({law})"


def change_text(change: float | None, law: str | None = None, *, angle: bool = False, digits: int = 2) -> str:
    """A run's change with its sign (an angle with its unit) and, where known, its law: ``+1.95e-03 gains ∝ t``,
    ``-1.9e-03 damps ∝ t``, ``7.1e-03 rad turns ∝ t``, ``—`` where the invariant is not kept; ``digits`` after the
    point."""
    if change is None:
        return "—"
    number = f"{change:.{digits}e} rad" if angle else f"{change:+.{digits}e}"
    return f"{number} {law}" if law else number
