"""The boxes benchmark (GitHub ``scpeters/benchmark``: ``boxes.cc``, ``boxes_description.ipynb``), its definitions
stated once, and the figures it published for ODE, Bullet, Simbody and DART (``boxes_published.csv``).

What we matched, definition by definition (their ``boxes.cc``, ``BoxesTest::Boxes``):

* the body: a uniform box of 10 kg, 0.1 x 0.4 x 0.9 m, identity start at the origin (``models/box.xml``);
* the cases: **simple**, no gravity, v0 = [-0.9, 0.4, 0.1] m/s, w0 = [0.5, 0, 0] rad/s; **complex**, gravity
  [0, 0, -9.8] m/s^2, v0 = [-2, 2, 8] m/s, w0 = [0.1, 5, 0.1] rad/s (world components; the start is the identity,
  so body components too);
* the run: ``steps = ceil(10 / dt)`` steps of ``dt`` (so 10.0002 s at dt = 3e-4, as their ``simTime`` column);
  the statistics over the states after each step (t = dt ... steps dt, not t = 0);
* the angular momentum error: ``max |H(t) - H0| / |H0|``, H about the centre of mass in world components,
  ``R I w`` (their ``(H - H0) / H0mag``, the magnitude's largest value: ``Vector3Stats::Mag`` of ``maxAbs``).
  **Relative: dimensionless**, not kg m^2/s;
* the energy error: ``max |E(t) - E0| / E0`` with ``E = 1/2 m |v|^2 + 1/2 w.I w - m g.c`` (their notebook's T + V;
  ``GetWorldEnergy``), E0 from the initial state (their constants 5.001041625 and 368.5464125 J are 1e-8 below it (8e-9 and 1.1e-8):
  worked out with the moments rounded to six digits; their published simple-case energy errors of 0 show that the
  runs measured from the initial state's own energy);
* the centre of mass errors: ``max |c(t) - (c0 + v0 t + g t^2/2)|`` [m] and ``max |v(t) - (v0 + g t)|`` [m/s].

Our integrators fly the attitude only: their centre of mass is the exact parabola, so the translation adds
nothing to their errors (their energy error is the rotational energy's, over the same E0). Core: numpy only.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import rotations as rot

#: Their box: mass [kg], edge lengths [m]
MASS = 10.0
EDGES = (0.1, 0.4, 0.9)
#: Its principal moments about the centre [kg m^2], m/12 (b^2 + c^2, ...) = (97, 82, 17)/120
INERTIA = tuple(MASS / 12.0 * (EDGES[(k + 1) % 3] ** 2 + EDGES[(k + 2) % 3] ** 2) for k in range(3))
DURATION = 10.0
#: Their steps [s], 1e-4 ... 1e-3
STEPS = tuple(round(1e-4 * k, 4) for k in range(1, 11))
PUBLISHED_ENGINES = ("ode", "bullet", "simbody", "dart")
SOURCE = ("GitHub scpeters/benchmark, test_results/BENCHMARK_boxes_dt.csv at commit 55c3b05 (Apache-2.0, "
          "Open Source Robotics Foundation; Gazebo with each engine), read 2026-12-02")


@dataclass(frozen=True)
class Case:
    name: str  # "simple" | "complex"
    scenario: str  # the bundled scenario of its attitude cross-check
    gravity: tuple  # [m/s^2], world
    v0: tuple  # [m/s], world
    omega0: tuple  # [rad/s]; the start is the identity: world and body components alike
    what: str

    @property
    def energy0(self) -> float:
        """E0 [J] of the initial state (the centre of mass at the origin, V0 = 0): 4.9 + 97/960 and 360 + 8.546..."""
        w = np.asarray(self.omega0)
        return 0.5 * MASS * float(np.dot(self.v0, self.v0)) + 0.5 * float(np.dot(w, np.asarray(INERTIA) * w))


CASES = {
    "simple": Case("simple", "boxes-simple", (0.0, 0.0, 0.0), (-0.9, 0.4, 0.1), (0.5, 0.0, 0.0),
                   "no gravity, spun about the major axis (stable)"),
    "complex": Case("complex", "boxes-complex", (0.0, 0.0, -9.8), (-2.0, 2.0, 8.0), (0.1, 5.0, 0.1),
                    "gravity, spun near the intermediate axis (it tumbles)"),
}


def step_count(dt: float) -> int:
    """Their ``ceil(simDuration / _dt)``, in the same floating point."""
    return math.ceil(DURATION / dt)


def angular_momentum_error(q, omega) -> float:
    """``max_k |H_k - H_0| / |H_0|`` over the rows after the first, ``H = R(q) I w`` (world, about the centre)."""
    H = rot.quat_rotate(np.asarray(q, dtype=float), np.asarray(omega, dtype=float) * np.asarray(INERTIA))
    return float(np.max(np.linalg.norm(H[1:] - H[0], axis=1)) / np.linalg.norm(H[0]))


def energy(case: Case, omega, c=None, v=None, t=None):
    """E = T + V along a run (J): with ``c``, ``v`` (n, 3) the run's own centre of mass; without, the exact parabola
    at the times ``t`` (our attitude-only methods)."""
    omega = np.asarray(omega, dtype=float)
    g = np.asarray(case.gravity)
    if c is None:
        t = np.asarray(t, dtype=float)[:, None]
        v = np.asarray(case.v0) + g * t
        c = np.asarray(case.v0) * t + 0.5 * g * t * t
    rotational = 0.5 * np.sum(omega * np.asarray(INERTIA) * omega, axis=1)
    return 0.5 * MASS * np.sum(np.asarray(v) ** 2, axis=1) + rotational - MASS * np.asarray(c) @ g


def energy_error(case: Case, omega, c=None, v=None, t=None) -> float:
    """``max_k |E_k - E0| / E0`` over the rows after the first (E0: the case's initial energy)."""
    E = energy(case, omega, c, v, t)
    return float(np.max(np.abs(E[1:] - case.energy0)) / case.energy0)


def translation_errors(case: Case, t, c, v) -> tuple[float, float]:
    """The centre of mass's largest position [m] and velocity [m/s] errors against the exact parabola."""
    t = np.asarray(t, dtype=float)[1:, None]
    g = np.asarray(case.gravity)
    c_exact = np.asarray(case.v0) * t + 0.5 * g * t * t
    v_exact = np.asarray(case.v0) + g * t
    return (float(np.max(np.linalg.norm(np.asarray(c)[1:] - c_exact, axis=1))),
            float(np.max(np.linalg.norm(np.asarray(v)[1:] - v_exact, axis=1))))


def published() -> list[dict]:
    """Their figures: ``[{case, engine, dt, momentum_error, energy_error, position_error, velocity_error,
    sim_time}]``."""
    path = Path(__file__).with_name("boxes_published.csv")
    with path.open() as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    return [{k: (v if k in ("case", "engine") else float(v)) for k, v in r.items()} for r in rows]
