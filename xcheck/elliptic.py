"""Elliptic functions and integrals for the closed forms (:mod:`xcheck.reference`), with the complementary parameter
``m1 = 1 - m`` given separately so that neither is a difference of nearly equal numbers: exact near m = 0 (a nearly
axisymmetric body) and near m = 1 (near a separatrix), where scipy's ``ellipj`` is not (it forms 1 - m itself).

* :func:`complete_k` — ``K(m)``, Carlson's ``R_F(0, m1, 1)``;
* :func:`jacobi` — ``sn, cn, dn`` by the arithmetic-geometric mean;
* :func:`elliptic_argument` — ``F(phi | m)`` for ``phi = atan2(sn, cn)``;
* :func:`legendre_pi` — Legendre's integral of the third kind along ``am(tau)``, continued past the quarter
  periods, in Carlson's symmetric forms (DLMF 19.25).
"""

from __future__ import annotations

import numpy as np
from scipy.special import elliprf, elliprj

__all__ = ["complete_k", "jacobi", "elliptic_argument", "legendre_pi"]


def complete_k(m1: float) -> float:
    """``K(m) = R_F(0, m1, 1)`` (DLMF 19.25.1) from the complementary parameter ``m1 = 1 - m``: accurate as m -> 1,
    infinite at m1 = 0 (the separatrix)."""
    return float(elliprf(0.0, m1, 1.0)) if m1 > 0 else np.inf


def jacobi(u, m: float, m1: float):
    """``sn, cn, dn`` of ``u`` (any shape, ``|u| <= K`` for full accuracy) at parameter ``m`` (``m1 = 1 - m`` given
    separately, so that neither is a difference of nearly equal numbers): the arithmetic-geometric mean and its
    descending back-substitution (Abramowitz & Stegun 16.4), started from ``b0 = sqrt(m1)`` instead of
    ``sqrt(1 - m)``; ``dn = sqrt(cn^2 + m1 sn^2)``, without the cancellation of ``1 - m sn^2``. (scipy's ``ellipj``
    computes ``1 - m`` itself and approximates to first order in it below 1e-9: 1.25e-11 off in sn at m1 = 1e-10.)"""
    u = np.asarray(u, dtype=float)
    if m1 == 0.0:  # the separatrix: sn = tanh, cn = dn = sech
        return np.tanh(u), 1.0 / np.cosh(u), 1.0 / np.cosh(u)
    a, b, c = 1.0, np.sqrt(m1), np.sqrt(m)
    ratios = []
    while abs(c) > 1e-17 * a and len(ratios) < 64:
        a, b, c = 0.5 * (a + b), np.sqrt(a * b), 0.5 * (a - b)
        ratios.append(c / a)
    phi = (2.0 ** len(ratios)) * a * u
    for r in reversed(ratios):
        phi = 0.5 * (np.arcsin(r * np.sin(phi)) + phi)
    sn, cn = np.sin(phi), np.cos(phi)
    return sn, cn, np.sqrt(cn * cn + m1 * sn * sn)


def elliptic_argument(sn: float, cn: float, m1: float) -> float:
    """``F(phi | m)`` for ``phi = atan2(sn, cn)`` in ``(-pi, pi]`` (``sn^2 + cn^2 = 1``): Carlson's
    ``s R_F(c^2, d^2, 1)`` (DLMF 19.25.5) with ``d^2 = cn^2 + m1 sn^2``, reflected about ``+-K`` beyond a quarter period."""
    value = sn * float(elliprf(cn * cn, cn * cn + m1 * sn * sn, 1.0))
    return value if cn >= 0 else np.sign(sn) * 2 * complete_k(m1) - value


def legendre_pi(n, m, m1, tau, *, one_minus_n=None):
    """``(sn, cn, dn)`` at ``tau`` and Legendre's incomplete integral of the third kind along it,
    ``Pi(n; am tau | m) = int_0^tau du / (1 - n sn^2 u)`` (n < 1; ``m1 = 1 - m``), continued past the quarter
    periods (``Pi(n; phi + j pi) = Pi(n; phi) + 2 j Pi(n | m)``): ``tau`` is reduced to ``[-K, K)`` first, where
    Carlson's symmetric forms give it to a few ulps (DLMF 19.25.14, 19.25.2),
    ``Pi(n; phi) = s R_F(c^2, d^2, 1) + n/3 s^3 R_J(c^2, d^2, 1, 1 - n s^2)`` with ``s, c, d = sn, cn, dn``.
    No quadrature: each time is computed on its own, to round-off whatever the grid. ``one_minus_n``: ``1 - n``
    given accurately (n close to 1); then ``1 - n s^2 = (1 - n) + n c^2``, a sum of terms >= 0."""
    tau = np.asarray(tau, dtype=float)
    one_minus_n = 1.0 - n if one_minus_n is None else one_minus_n
    K = complete_k(m1)
    if np.isfinite(K):
        j = np.floor((tau + K) / (2 * K))
        tau_r = tau - 2 * K * j
    else:  # the separatrix (m = 1): no period
        j, tau_r = np.zeros_like(tau), tau
    sn, cn, dn = jacobi(tau_r, m, m1)
    s2 = sn * sn
    x, y = cn * cn, dn * dn
    p = one_minus_n + n * x if n > 0 else 1.0 - n * s2
    value = sn * elliprf(x, y, 1.0) + (n / 3.0) * sn * s2 * elliprj(x, y, 1.0, p)
    if np.isfinite(K) and np.any(j):
        complete = elliprf(0.0, m1, 1.0) + (n / 3.0) * elliprj(0.0, m1, 1.0, one_minus_n)
        value = value + 2 * j * complete
        sign = 1.0 - 2.0 * (j % 2)  # sn and cn change sign every half period 2K
        sn, cn = sign * sn, sign * cn
    return (sn, cn, dn), value
