"""Butcher tableaux: a Runge-Kutta method is data (exact fractions); the kernels generate each one's stage loop from
them (:func:`xcheck.integrators.kernels.rk_step_for`)."""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction as F

import numpy as np

__all__ = ["ButcherTableau", "RK4", "RK38", "KUTTA3", "THESIS_172_DEXP_A"]


@dataclass(frozen=True)
class ButcherTableau:
    """An explicit Runge-Kutta method: ``A`` strictly lower triangular, weights ``b``, nodes ``c``.

    Consistency conditions (checked by the tests for every tableau): ``sum(b) == 1`` and
    ``A.sum(1) == c``; ``order`` is the classical order of the method.
    """

    name: str
    A: tuple[tuple[F, ...], ...]
    b: tuple[F, ...]
    c: tuple[F, ...]
    order: int

    @property
    def stages(self) -> int:
        return len(self.b)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``A`` (s, s), ``b`` (s,), ``c`` (s,) as float64 arrays for the kernels."""
        return (np.array(self.A, dtype=float), np.array(self.b, dtype=float), np.array(self.c, dtype=float))


_0, _1, _2 = F(0), F(1), F(1, 2)

#: The classical fourth-order method (seed 004 algorithms 157, 163 and 172 are all written with it).
RK4 = ButcherTableau(
    name="classical Runge-Kutta",
    A=((_0, _0, _0, _0), (_2, _0, _0, _0), (_0, _2, _0, _0), (_0, _0, _1, _0)),
    b=(F(1, 6), F(1, 3), F(1, 3), F(1, 6)),
    c=(_0, _2, _2, _1),
    order=4,
)

#: Seed 004 algorithm 172 as printed: the third stage's dexp^-1 argument is 1/2 k1 where the RKMK
#: method (and the stage's own attitude, p0 ∘ exp(1/2 k2)) uses 1/2 k2. Measured (seed 001 gyroscope,
#: 10 s, exact reference): order 2.00 as printed (1.1e-8 rad at dt = 1/256 s) against 4.00 for the
#: RKMK4 form (2.3e-12 rad): ``lie-rkmk4`` is the corrected method, ``lie-thesis-172`` the printed one.
THESIS_172_DEXP_A = ((_0, _0, _0, _0), (_2, _0, _0, _0), (_2, _0, _0, _0), (_0, _0, _1, _0))

_3, _23 = F(1, 3), F(2, 3)

#: Kutta's 3/8 rule (1901), fourth order: the classical method's sibling (Hairer, Nørsett & Wanner, Solving ODEs I,
#: table II.1.2).
RK38 = ButcherTableau(
    name="3/8 rule",
    A=((_0, _0, _0, _0), (_3, _0, _0, _0), (-_3, _1, _0, _0), (_1, -_1, _1, _0)),
    b=(F(1, 8), F(3, 8), F(3, 8), F(1, 8)),
    c=(_0, _3, _23, _1),
    order=4,
)

#: Kutta's third-order method (1901; Hairer, Nørsett & Wanner, table II.1.1).
KUTTA3 = ButcherTableau(
    name="Kutta 3",
    A=((_0, _0, _0), (_2, _0, _0), (-_1, F(2), _0)),
    b=(F(1, 6), F(2, 3), F(1, 6)),
    c=(_0, _2, _1),
    order=3,
)
