"""xcheck: a MuJoCo-validated dynamics cross-checker for rigid-body attitude motion.

Conventions (see :mod:`xcheck.rotations`): quaternions ``[w, x, y, z]``, body->world, Hamilton product;
``R`` maps body components to world components (MuJoCo's ``xmat``); body rates in body components; SI units.
"""

__version__ = "0.1.0"
