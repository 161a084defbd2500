"""Torque models as data, and the magnetic field models a scenario can swap by name.

A torque model (:class:`TorqueModel`) is an integer kind, a parameter vector ``P`` and a table ``T``:
:func:`torque_eval` (compiled, :mod:`.kernel`) evaluates any model from that data without a Python call per
stage, and every model is also a Python callable ``model(t, q, omega) -> (3,)`` [N m] (the same compiled
function) for scipy, MuJoCo's callback and plotting. Any other Python callable with that signature is accepted
by :func:`xcheck.integrators.integrate` too, on a slower, interpreted path.

Magnetic torque (seed 004 eq. 174): ``t' = mu0 (M_p x H)`` in body components, ``M_p`` the permanent dipole
[A m^2], ``H`` the field strength [A/m]. The field models, by the name a scenario gives them (:data:`FIELDS`):

* ``body-table`` (:class:`BodyFieldTable`): H in body components from a CSV time series, linearly
  interpolated; the torque does not depend on attitude (the thesis's set-up).
* ``world-table`` (:class:`WorldFieldTable`): the same in world components.
* ``orbit-dipole`` (:class:`OrbitDipoleField`): a tilted dipole Earth field (IGRF 2010 dipole terms) along a
  circular orbit, fixed in inertial space: ``H_body = R^T H_world``, the torque depends on attitude.
* ``igrf`` (:class:`IGRFField`, optional extra ``igrf``): the full IGRF along the same orbit at an epoch,
  tabulated in world components every 0.5 s and linearly interpolated.
* ``uniform`` (:class:`UniformField`): a constant field in world components.

Rooms: :mod:`.kernel` (the compiled evaluation and ``P``'s named slots), :mod:`.models` (torque models, the
:class:`Field` declaration, the table and uniform fields), :mod:`.tables` (CSV I/O), :mod:`.orbit` (orbit maths,
the dipole Earth), :mod:`.igrf`, :mod:`.rax1` (seed 004's RAX-1 set-up and its synthetic table).

Adding a field model: a :class:`Field` subclass declaring ``name``, ``keys``, ``slots``, ``frame`` and
``evaluator`` (an existing one, or a new branch of :func:`.kernel.field_body`), and its entry in
:data:`FIELDS`. The scenario reader, the torque builder and their messages read :data:`FIELDS` only.
"""

from __future__ import annotations

from .igrf import IGRFField
from .kernel import MU0, torque_eval, torque_needs_attitude, torque_needs_rate
from .models import (
                     BodyFieldTable,
                     ConstantTorque,
                     Field,
                     GravityTorque,
                     Key,
                     MagneticTorque,
                     SumTorque,
                     TorqueModel,
                     UniformField,
                     WheelsTorque,
                     WorldFieldTable,
                     magnetic_torque,
)
from .orbit import IGRF2010_DIPOLE_NT, RAX1_ORBIT, GravityGradientTorque, OrbitDipoleField, orbit_position
from .surface import AerodynamicTorque, SolarPressureTorque
from .rax1 import (
                     SEED004_INITIAL_TORQUE,
                     nearest_achievable_torque,
                     rax1_orbit_phase_residual,
                     rax1_synthetic_body_table,
                     write_rax1_body_table,
)
from .tables import load_field_table, write_field_table

__all__ = [
    "MU0", "FIELDS", "Field", "Key", "TorqueModel", "ConstantTorque", "MagneticTorque", "GravityTorque",
    "SumTorque", "GravityGradientTorque", "WheelsTorque", "SolarPressureTorque", "AerodynamicTorque",
    "BodyFieldTable",
    "WorldFieldTable", "UniformField", "OrbitDipoleField", "IGRFField", "torque_eval", "torque_needs_attitude",
    "torque_needs_rate",
    "magnetic_torque", "load_field_table", "write_field_table", "orbit_position", "RAX1_ORBIT",
    "IGRF2010_DIPOLE_NT", "SEED004_INITIAL_TORQUE", "nearest_achievable_torque", "rax1_orbit_phase_residual",
    "rax1_synthetic_body_table", "write_rax1_body_table",
]

#: Field models by the name a scenario gives them (``[torque] field = "..."``).
FIELDS: dict[str, type[Field]] = {cls.name: cls for cls in (
    BodyFieldTable, WorldFieldTable, OrbitDipoleField, IGRFField, UniformField)}
