"""The integrators' hot loop: every integration scheme as one declaration, the Runge-Kutta stage loop generated
from each Butcher tableau, and each scheme's stage derivative written as the seed writes it.

The files say what they hold:

    registry.py    Scheme, declare: what a scheme is; the status codes
    helpers.py     quaternion and so(3) arithmetic, Euler's equation, the rigid body's tail (torque + Euler)
    schemes.py     one section per scheme: its derivative (the seed's equation cited), hooks, encode/decode
    lanes.py       a batch of bodies in lockstep (Formulation II, the Lie-group method)
    steps.py       the dispatch by scheme, the stage loop generated per tableau (rk_step_for), CF4's step
    loops.py       run (a trajectory's steps), the entry points made per scheme and step, run_one, run_many
    _variant.py    compiled or interpreted: what that changes (jit, the torque's evaluation)

A *scheme* (:class:`Scheme`, registered with :func:`declare`) is everything the kernels need to know about a
method: its state's layout (:func:`layout`: named parts, ``LIE_STATE = layout(p_n=4, u=3, w=3)``, the part held
constant in a step named), its stage derivative, optional hooks before and after a step (chart changes,
projections), the kind of step (the tableau stage loop, or the commutator-free step), the layout of the scratch its
derivative, hooks and step share, and how ``(q, omega)`` become its state and back (encode, decode). The code reads
the parts by name (``y[S.w]``, ``work[W.tau]``: constants to the compiler, as cheap as ``y[7:10]``); the sizes the
shared loops need (``STATE_SIZE``, ``FIRST``, ``WORK_SIZE`` by scheme id) are read from the declarations.
:data:`xcheck.integrators.METHODS` names the schemes and gives each its tableau, order and seed. Adding a method
with a new state layout is its section in ``schemes.py``, ending in ``declare(...)``, one ``METHODS`` entry and the
README's table; a method on an existing scheme with another tableau is one ``METHODS`` entry.

States (``y``; ``q`` is [w, x, y, z] body -> world, ``w`` the body rate):

===========  ======================================  =============================================
scheme       y                                       seed
===========  ======================================  =============================================
EULER        angles(3), w(3)                         seed 001 appendix A (any of the 12 sequences)
F1           p(4), p'(4)                             seed 004 §2.3, eq. 150-157
F2           p(4), w(3)                              seed 004 §2.4, eq. 158-163
LIE          p_n(4), u(3), w(3)                      seed 004 §2.5, eq. 166-172 (u = 0 at each step)
CF4          p_n(4), u(3) = 0, w(3)                  commutator-free Lie group method of order 4
DCM          R(9, row-major), w(3)                   seed 000 eq. 1.7, §1.7.1
GIBBS        q_ref(4), g(3), w(3)                    seed 000 §1.4.2 (chart re-centred when |g| > 1)
ROTVEC       q_ref(4), phi(3), w(3)                  seed 000 §1.5.2 (chart re-centred when |phi| > pi)
MRP          s(3), w(3)                              Schaub & Junkins (Basilisk's attitude: shadow set
                                                     when |s| > 1 after each step)
LGVI         p(4), w(3)                              Lee, Leok & McClamroch 2005 (implicit, its own step)
SPLIT2/4     p(4), w(3)                              Celledoni, Fassò, Säfström & Zanna 2008 (torque kicks
                                                     around the exact free flow; Strang, Yoshida's triple jump)
===========  ======================================  =============================================

How it is fast: numba compiles it (``cache=True``: once per user and release, into the folder of
:mod:`xcheck._jit`; then loaded in ~0.2 s). Each scheme has two entry points made from the registry
(:func:`_entry_points`: ``run_<name>``, ``many_<name>``) in which the scheme is a compile-time constant and
its step function is named, and the dispatchers (:func:`deriv`, the hooks) are overloads that keep only that
scheme's code: each scheme compiles and is cached on its own. Inside one step:

- nothing allocates and nothing counts references: the loop and its helpers are compiled without numba's
  runtime (``_nrt=False``), the scratch arrays come from the caller (:func:`scratch`). A slice such as
  ``work[0:3]`` is then a free view; with the runtime, each one cost an atomic reference count, and the
  single-trajectory step took 1.1-2.1 us instead of 0.14-0.5 us;
- the stage loop, the stage derivatives, the hooks, Euler's equation and the torque's dispatch are inlined
  (``ijit``: a call passes ~7 machine words per array); the small kinematic helpers and the field
  evaluators (:func:`xcheck.fields.kernel.magnetic_torque`) stay calls, compiled once (``jit``): inlining
  them too bought < 5 % for 1-2 s more compile per scheme;
- a batch is the same compiled single-trajectory loop called for each row in parallel threads, each row
  with its own scratch: one loop, one compile; for Formulation II and the Lie-group method, blocks of bodies in
  lockstep (section LANES), the same scalar arithmetic in loops over the bodies that become vector
  instructions (5x the body-steps a second, the same numbers).

Kernel arguments are one named record (:class:`~xcheck.integrators.kernel_args.KernelArgs`), unpacked once
per run; derivatives and hooks take plain arguments.

Variants: :func:`xcheck.integrators._kernels_for` loads this same package under another name with
``VARIANT = "python"`` set on it before its modules run: ``jit`` is then the identity, and the same code is interpreted for
a Python torque callable. One code path per method, fast or general.
"""

#: Which variant this package is: set by the loader before the package runs (``_kernels_for``); the package
#: imported normally is the compiled one. Read by :mod:`._variant` as the package's modules run.
VARIANT = globals().get("VARIANT", "compiled")

from .freeflow import MAX_PIECES, MAX_TURN  # noqa: E402
from .lanes import LANES  # noqa: E402
from .loops import entry_points, run_many, run_one, scratch, step_of  # noqa: E402
from .registry import (INTERRUPTED, NONFINITE, NOT_CONVERGED, OK, OVER_BUDGET, SCHEMES, SINGULAR, Scheme,  # noqa: E402
                       declare, layout, size_of)
from .schemes import (CF4, DCM, EULER, F1, F2, FIRST, GIBBS, LGVI, LGVI_WORK, LIE, MRP, ROTVEC, SPLIT2,  # noqa: E402
                      SPLIT4, STATE_SIZE, WORK_SIZE)
from .steps import LGVI_MOST_SUBSTEPS, RK4_STEP, rk_step_for, rk_step_source  # noqa: E402

__all__ = ["VARIANT", "MAX_PIECES", "MAX_TURN", "LANES", "entry_points", "run_many", "run_one", "scratch", "step_of",
           "NONFINITE", "NOT_CONVERGED", "INTERRUPTED", "OVER_BUDGET", "LGVI", "LGVI_WORK", "LGVI_MOST_SUBSTEPS",
           "SPLIT2", "SPLIT4", "OK", "SCHEMES", "SINGULAR", "Scheme", "declare", "layout", "size_of", "CF4", "DCM",
           "EULER", "F1", "F2", "FIRST", "GIBBS", "LIE", "MRP", "ROTVEC", "STATE_SIZE", "WORK_SIZE", "RK4_STEP",
           "rk_step_for", "rk_step_source"]
