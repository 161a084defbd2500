"""A scenario's torque as data: one ``[torque]`` table (a dict), a ``[[torque]]`` list of them (summed at every
stage, issue 28), or None; what every reader of ``Scenario.torque`` goes through."""

from __future__ import annotations

__all__ = ["TORQUE_KINDS", "torque_terms", "magnetic_term", "copy_torque"]

#: The kinds a scenario's [torque] may be (each term of a [[torque]] list too).
TORQUE_KINDS = ("magnetic", "constant", "gravity-gradient", "solar-pressure", "aerodynamic")


def torque_terms(spec) -> list[dict]:
    """A scenario's torque as a list of its terms: ``[]`` torque free, one ``[torque]`` table, or each of
    ``[[torque]]``'s (summed at every stage)."""
    return [] if spec is None else list(spec) if isinstance(spec, list) else [spec]


def magnetic_term(spec) -> dict | None:
    """The magnetic term of a scenario's torque (what a sweep's dipole and field axes change), or None."""
    return next((t for t in torque_terms(spec) if t.get("kind") == "magnetic"), None)


def copy_torque(spec):
    """A copy of a scenario's torque whose terms can be changed (a sweep's cell)."""
    return None if spec is None else [dict(t) for t in spec] if isinstance(spec, list) else dict(spec)
