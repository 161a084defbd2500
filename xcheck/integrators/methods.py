"""The registry of our integrators: name -> the kernel scheme it runs (:mod:`.kernels`, which also says how
``(q0, omega0)`` become its state and back), the tableau, the order, the seed."""

from __future__ import annotations

from dataclasses import dataclass

from . import kernels as K
from .tableau import RK4, THESIS_172_DEXP_A, ButcherTableau

__all__ = ["Method", "METHODS"]


@dataclass(frozen=True)
class Method:
    """One integrator.

    ``kernel`` is a scheme of :mod:`xcheck.integrators.kernels` (None: not a fixed-step kernel method);
    ``expected_order`` None means adaptive (no order in the step); ``dexp_A`` the dexp-argument matrix of
    the printed algorithm 172 (None: the tableau's own); ``tolerances``: an adaptive method's default relative
    and absolute tolerances (an ``rtol`` given to it keeps their proportion); ``demonstration``: why the method
    exists although nobody should use it (a seed's misprint shown at work): the report never recommends it."""

    name: str
    kernel: int | None
    expected_order: int | None
    summary: str
    seed: str
    tableau: ButcherTableau = RK4
    dexp_A: tuple | None = None
    tolerances: tuple | None = None
    demonstration: str | None = None

    def __post_init__(self):
        if self.kernel is not None:  # an implicit tableau is refused when the method is made, not when it first runs
            K.step_of(self.kernel, self.tableau, self.dexp_A)

    @property
    def adaptive(self) -> bool:
        return self.tolerances is not None

    @property
    def stages(self) -> int:
        """Right-hand-side evaluations a step (the commutator-free step has four whatever the tableau; the variational
    integrator evaluates the torque at the step's start and end, once more to confirm the end's; a splitting once a
    Strang step, its end's being the next start's)."""
        step = K.SCHEMES[self.kernel].step
        return {"cf4": 4, "lgvi": 2, "split2": 1, "split4": 3}.get(step, self.tableau.stages)

    @property
    def exact_torque_free(self) -> bool:
        """Whether its step is the exact free flow where there is no torque (a splitting's): no order to measure
        there."""
        return self.kernel is not None and K.SCHEMES[self.kernel].step in ("split2", "split4")

    @property
    def encode(self):
        """``(q0 (..., 4), omega0 (..., 3), sequence) -> y0`` of the kernel's state."""
        return K.SCHEMES[self.kernel].encode

    @property
    def decode(self):
        """``(y (n, size), sequence) -> (q, omega, extras)``."""
        return K.SCHEMES[self.kernel].decode


METHODS: dict[str, Method] = {m.name: m for m in [
    Method("euler-rk4", K.EULER, 4, "RK4 on Euler angles and Euler's equations (any of the 12 sequences)",
           "seed 001, appendix A"),
    Method("formulation-1", K.F1, 4, "RK4 on the quaternion DAE at acceleration level; normalise p, project p'",
           "seed 004 §2.3, eq. 150-157"),
    Method("formulation-2", K.F2, 4, "RK4 on (p, w'), p' = 1/2 G^T w'; normalise p", "seed 004 §2.4, eq. 158-163"),
    Method("lie-rkmk4", K.LIE, 4, "Runge-Kutta-Munthe-Kaas 4 on so(3) with dexp^-1 and exp_S3 (unit norm by "
           "construction)", "seed 004 §2.5, eq. 166-172 (third stage corrected)"),
    Method("lie-thesis-172", K.LIE, 2, "seed 004 algorithm 172 as printed (1/2 k1 in the third stage's dexp^-1)",
           "seed 004 §2.5, eq. 172", dexp_A=THESIS_172_DEXP_A,
           demonstration="seed 004's algorithm 172 as printed, to show its misprint: order 2 where lie-rkmk4, the "
                         "same method corrected, has order 4"),
    Method("lie-cf4", K.CF4, 4, "commutator-free Lie group method of order 4 on S3: exponentials of stage rates, "
           "no dexp^-1 (Celledoni, Marthinsen, Owren 2003)", "seed 004 §2.5's state, CMO 2003 CF4"),
    Method("dcm-rk4", K.DCM, 4, "RK4 on R' = R [w x]; Björck-Bowie orthonormalisation after each step",
           "seed 000 eq. 1.7, §1.7.1"),
    Method("gibbs-rk4", K.GIBBS, 4, "RK4 on the Gibbs vector (chart re-centred beyond 90 deg)", "seed 000 §1.4"),
    Method("rotvec-rk4", K.ROTVEC, 4, "RK4 on the rotation vector with the non-commutativity term (chart "
           "re-centred beyond 180 deg)", "seed 000 §1.5"),
    Method("mrp-rk4", K.MRP, 4, "RK4 on the modified Rodrigues parameters (shadow set when |s| > 1 after a step): "
           "the kinematics Basilisk's hub integrates", "Schaub & Junkins; Basilisk's spacecraft hub"),
    Method("lie-lgvi", K.LGVI, 2, "Lie group variational integrator: implicit, symplectic, the world momentum kept "
           "torque free, the energy error bounded (Newton on the step's Cayley vector)",
           "Lee, Leok & McClamroch 2005; forced form, 2007 eq. 50-53"),
    Method("split-strang", K.SPLIT2, 2, "Strang splitting: half torque kicks around the exact free rigid-body flow "
           "(Jacobi elliptic functions); symplectic under a potential, exact torque free",
           "Celledoni, Fassò, Säfström & Zanna 2008 (ACM TOMS Algorithm 903)"),
    Method("split-yoshida4", K.SPLIT4, 4, "Yoshida's triple jump of the Strang splitting around the exact free flow: "
           "order 4, symplectic under a potential, exact torque free",
           "Celledoni et al. 2008 §5; Yoshida 1990"),
    Method("scipy-rk45", None, None, "scipy solve_ivp RK45 (its defaults rtol 1e-3, atol 1e-6: seed 001's choice), "
           "sampled on the output grid", "seed 001, appendix A (its own choice)", tolerances=(1e-3, 1e-6)),
]}
