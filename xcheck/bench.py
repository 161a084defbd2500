"""``xcheck bench``: steps per second of every method, single trajectory and batched, next to MuJoCo's own
rate for the same body and integrator, measured in the same run.

Rows (``--json PATH`` writes ``{"schema": "xcheck.bench/1", "versions": ..., "results": [...]}``):

* ``xcheck`` / method / ``gyroscope-nonsingular`` / batch 1: one torque-free 10 s run at dt = 1/1024 s.
* ``xcheck`` / method / ``gyroscope-nonsingular`` / batch 10000: :func:`integrate_batch`, 100 steps each,
  in body-steps per second.
* ``xcheck`` / method / ``rax1-orbit-field`` / batch 1: the attitude-dependent orbit-dipole torque.
* ``mujoco`` / ``mujoco-<integrator>`` / ``gyroscope-nonsingular``: torque-free via ``rollout``; and
  ``mj_step`` in a plain Python loop (``mujoco-rk4 (mj_step loop)``), MuJoCo's own per-step rate.
* ``mujoco`` / ``mujoco-rk4`` / ``rax1-orbit-field``: our torque in MuJoCo's control callback.

Compilation is done before timing; each figure is the best of ``repeat`` runs.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from . import rotations as rot
from .integrators import METHODS, integrate, integrate_batch
from .versions import versions

GYRO_INERTIA = np.array([0.005625, 0.0028125, 0.0028125])


def _best(fn, repeat):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def run_bench(*, repeat: int = 3, batch: int = 10_000, quick: bool = False, progress=None) -> list[dict]:
    """Measure and return the rows (see the module docstring)."""
    from .engines.mujoco import simulate
    from .fields import MagneticTorque, OrbitDipoleField
    from .models import BUNDLED_MODELS

    ang = np.radians([0.0, 15.0, 0.0])
    q0 = rot.euler_to_quat(ang, "323")
    w0 = rot.euler_rates_to_omega(ang, [0.02, 0.02, 15.71], "323")
    rax_q0 = rot.quat_normalize([-0.4583, -0.6558, 0.5997, 0.0182])
    rax_w0 = np.radians([1.5, -1.0, 0.5])
    rax_I = np.array([0.018, 0.018, 0.006])
    torque = MagneticTorque([0.14, 0.02, 1.09], OrbitDipoleField())
    duration = 2.0 if quick else 10.0
    dt = 1 / 1024
    nsteps = round(duration / dt)
    batch = min(batch, 1000) if quick else batch
    rng = np.random.default_rng(0)
    Q = np.tile(q0, (batch, 1))
    W = w0 + rng.normal(0.0, 0.01, (batch, 3))
    rows = []

    def add(engine, method, scenario, n, seconds, steps):
        rows.append({"engine": engine, "method": method, "scenario": scenario, "batch": n,
                     "steps_per_second": float(n * steps / seconds)})
        if progress:
            progress(rows[-1])

    fixed = [m for m, info in METHODS.items() if info.kernel is not None]
    for method in fixed:
        integrate(method, GYRO_INERTIA, q0, w0, dt=dt, duration=0.01)  # compile outside the timing
        sec = _best(lambda: integrate(method, GYRO_INERTIA, q0, w0, dt=dt, duration=duration), repeat)
        add("xcheck", method, "gyroscope-nonsingular", 1, sec, nsteps)
    for method in ("formulation-2", "lie-rkmk4", "lie-cf4"):
        integrate(method, rax_I, rax_q0, rax_w0, dt=dt, duration=0.01, torque=torque)
        sec = _best(lambda: integrate(method, rax_I, rax_q0, rax_w0, dt=dt, duration=duration, torque=torque), repeat)
        add("xcheck", method, "rax1-orbit-field", 1, sec, nsteps)
    for method in fixed:
        integrate_batch(method, GYRO_INERTIA, Q[:2], W[:2], dt=0.01, duration=0.02)
        sec = _best(lambda: integrate_batch(method, GYRO_INERTIA, Q, W, dt=0.01, duration=1.0), repeat)
        add("xcheck", method, "gyroscope-nonsingular", batch, sec, 100)
    sec = _best(lambda: integrate("scipy-rk45", GYRO_INERTIA, q0, w0, dt=dt, duration=duration), 1)
    add("xcheck", "scipy-rk45", "gyroscope-nonsingular", 1, sec, nsteps)

    gyro = BUNDLED_MODELS / "gyroscope.xml"
    for integrator in ("rk4", "euler", "implicit", "implicitfast"):
        sec = _best(lambda: simulate(gyro, integrator=integrator, q0=q0, omega0=w0, dt=dt, duration=duration),
                    repeat)
        add("mujoco", f"mujoco-{integrator}", "gyroscope-nonsingular", 1, sec, nsteps)
    add("mujoco", "mujoco-rk4 (mj_step loop)", "gyroscope-nonsingular", 1, _mj_step_loop(gyro, q0, w0, dt, nsteps),
        nsteps)
    rax = BUNDLED_MODELS / "rax1.xml"
    sec = _best(lambda: simulate(rax, integrator="rk4", q0=rax_q0, omega0=rax_w0, dt=dt, duration=duration,
                                 torque=torque), repeat)
    add("mujoco", "mujoco-rk4", "rax1-orbit-field", 1, sec, nsteps)
    return rows


def _mj_step_loop(path, q0, w0, dt, nsteps) -> float:
    """Seconds for ``nsteps`` bare ``mj_step`` calls (RK4) in a Python loop, no state read back."""
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.timestep = dt
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    d = mujoco.MjData(m)
    d.qpos[3:7] = q0
    d.qvel[3:6] = w0
    step = mujoco.mj_step
    t0 = time.perf_counter()
    for _ in range(nsteps):
        step(m, d)
    return time.perf_counter() - t0


def format_rows(rows) -> str:
    lines = [f"{'engine':8s} {'method':28s} {'scenario':24s} {'batch':>6s} {'steps/s':>10s}"]
    for r in rows:
        lines.append(f"{r['engine']:8s} {r['method']:28s} {r['scenario']:24s} {r['batch']:6d} "
                     f"{r['steps_per_second']:10.3g}")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="xcheck bench", description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", metavar="PATH", help="write the results as JSON (schema xcheck.bench/1)")
    parser.add_argument("--quick", action="store_true", help="shorter runs, smaller batch")
    parser.add_argument("--repeat", type=int, default=3, help="best of this many runs (default 3)")
    args = parser.parse_args(argv)
    rows = run_bench(repeat=max(1, args.repeat), quick=args.quick,
                     progress=(lambda r: print(f"  {r['engine']} {r['method']} {r['scenario']} batch={r['batch']}: "
                                               f"{r['steps_per_second']:.3g} steps/s", file=sys.stderr))
                     if sys.stderr.isatty() else None)
    print(format_rows(rows))
    if args.json:
        from .report.io import write_json_atomic

        write_json_atomic(args.json, {"schema": "xcheck.bench/1", "versions": versions(), "results": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
