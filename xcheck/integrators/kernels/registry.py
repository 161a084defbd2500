"""The registry of integration schemes (:class:`Scheme`, :func:`declare`) and the kernels' status codes."""

from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass


OK, SINGULAR, NONFINITE, NOT_CONVERGED, INTERRUPTED, OVER_BUDGET = 0, 1, 2, 3, 4, 5
#: INTERRUPTED: the run was asked to stop (SIGINT or SIGTERM: :func:`xcheck.base.interrupts.stop_flag`); OVER_BUDGET: a
#: step would take more work than a step may (:data:`xcheck.integrators.kernels.freeflow.MAX_PIECES`).

# so(3) coefficient series threshold [rad] (as in xcheck.rotations)
SERIES_ANGLE = 0.1


# ------------------------------------------------------------------------------------------------
# layouts: named parts of a state or of a scheme's scratch
# ------------------------------------------------------------------------------------------------
_LAYOUTS: dict = {}


def layout(**parts: int):
    """The named, consecutive parts of a flat array, in the order given: ``layout(p=4, w=3)`` is a named tuple of
    slices (``.p == slice(0, 4)``, ``.w == slice(4, 7)``). A compiled kernel reads one as a constant, so
    ``y[STATE.w]`` costs what ``y[4:7]`` does; :func:`size_of` is its length."""
    if not parts or any(not isinstance(n, int) or n <= 0 for n in parts.values()):
        raise ValueError(f"layout: parts must be positive sizes, got {parts}")
    names = tuple(parts)
    if names not in _LAYOUTS:
        _LAYOUTS[names] = namedtuple("Layout_" + "_".join(names), names)
    start, slices = 0, []
    for n in parts.values():
        slices.append(slice(start, start + n))
        start += n
    return _LAYOUTS[names](*slices)


def size_of(parts) -> int:
    """The length of a :func:`layout` (its last part's end)."""
    return parts[-1].stop


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
    is unaffected); ``step`` is ``"rk"`` (the stage loop generated for the method's tableau, :func:`rk_step_for`),
    ``"cf4"`` (:func:`cf4_step`), ``"lgvi"`` (:func:`lgvi_step`, implicit: its own Newton iterations), ``"split2"`` or
    ``"split4"`` (:func:`split2_step`, :func:`split4_step`: torque kicks around the exact free flow);
    ``state`` is the :func:`layout` of ``y``, whose part ``held`` (the first, when named: a reference quaternion) is
    constant within a step; ``work`` the layout of the scratch its derivative, hooks and step share (the parts each
    one uses, named; one that needs none: None). ``encode(q0 (..., 4), w0 (..., 3), seq) -> y0 (..., size)`` and
    ``decode(y (n, size), seq) -> (q, omega, extras)`` are plain Python."""

    name: str
    state: tuple
    deriv: object
    encode: object
    decode: object
    held: str | None = None
    before_step: object = None
    after_step: object = None
    step: str = "rk"
    work: tuple | None = None

    @property
    def size(self) -> int:
        """The length of the state ``y``."""
        return size_of(self.state)

    @property
    def first(self) -> int:
        """The first component integrated (those before it, the ``held`` part, are constant in a step)."""
        return 0 if self.held is None else getattr(self.state, self.held).stop

    @property
    def work_size(self) -> int:
        """The floats of scratch (at least one: an empty array is not a valid scratch row)."""
        return 1 if self.work is None else size_of(self.work)


SCHEMES: list = []


def declare(scheme: Scheme) -> int:
    """Register ``scheme``; returns its id (the compile-time constant of the entry points)."""
    if scheme.step not in ("rk", "cf4", "lgvi", "split2", "split4"):
        raise ValueError(f"{scheme.name}: unknown step {scheme.step!r}")
    if scheme.held is not None and scheme.held != scheme.state._fields[0]:
        raise ValueError(f"{scheme.name}: the held part {scheme.held!r} must be the state's first part")
    SCHEMES.append(scheme)
    return len(SCHEMES) - 1
