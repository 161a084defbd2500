"""The registry of integration schemes (:class:`Scheme`, :func:`declare`) and the kernels' status codes."""

from __future__ import annotations

from dataclasses import dataclass


OK, SINGULAR, NONFINITE = 0, 1, 2

# so(3) coefficient series threshold [rad] (as in xcheck.rotations)
SERIES_ANGLE = 0.1


# ------------------------------------------------------------------------------------------------
# the registry of schemes
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Scheme:
    """One integration scheme (see the module docstring).

    ``deriv(t, y, dy, ...) -> OK | SINGULAR`` writes the stage derivative of ``y`` into ``dy``; it names the
    inputs it needs among :data:`DERIV_ARGS` (``yhat``: the stage values of the dexp argument, only the printed
    algorithm 172 differs; ``tk, tP, tT`` the torque model; ``axes``, ``sing_tol`` for Euler angles; ``work``).
    ``before_step`` and ``after_step`` (inputs among :data:`HOOK_ARGS`) change ``y`` between steps, exactly (the order
    is unaffected); ``step`` is ``"rk"`` (the stage loop generated for the method's tableau, :func:`rk_step_for`) or
    ``"cf4"`` (:func:`cf4_step`);
    ``first`` components of ``y`` are constant within a step (a reference quaternion); ``work`` floats of
    scratch. ``encode(q0 (..., 4), w0 (..., 3), seq) -> y0 (..., size)`` and
    ``decode(y (n, size), seq) -> (q, omega, extras)`` are plain Python."""

    name: str
    size: int
    deriv: object
    encode: object
    decode: object
    first: int = 0
    before_step: object = None
    after_step: object = None
    step: str = "rk"
    work: int = 0


SCHEMES: list = []


def declare(scheme: Scheme) -> int:
    """Register ``scheme``; returns its id (the compile-time constant of the entry points)."""
    if scheme.step not in ("rk", "cf4"):
        raise ValueError(f"{scheme.name}: unknown step {scheme.step!r}")
    SCHEMES.append(scheme)
    return len(SCHEMES) - 1
