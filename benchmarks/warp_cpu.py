"""MuJoCo Warp (PyPI ``mujoco-warp``) on this machine's CPU: does it run, how fast, how accurate? (issue 29)

Run it in an environment with MuJoCo Warp installed (``pip install mujoco-warp`` beside xcheck; it brings NVIDIA's
``warp-lang``, whose CPU device compiles its kernels with LLVM), for example::

    python -m venv /tmp/warp && /tmp/warp/bin/pip install -q mujoco-warp -e . && /tmp/warp/bin/python benchmarks/warp_cpu.py --out docs/warp.md

It flies the tumbler (``models/tumbler.xml``, torque free, exact reference) with Warp's RK4 at three steps, one world,
and times one step of 1 and of 1000 worlds (``nworld``), the first call (its compilation) timed apart. It writes what
it measured as Markdown: the reason MuJoCo Warp is not one of xcheck's engines.
"""

import argparse
import contextlib
import io
import platform
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="write the findings as Markdown here")
    args = parser.parse_args(argv)
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            import mujoco
            import mujoco_warp as mjw
            import warp as wp
    except ImportError as exc:
        print(f"warp_cpu: MuJoCo Warp is not installed here ({exc}): pip install mujoco-warp", file=sys.stderr)
        return 2
    wp.config.quiet = True
    from xcheck.reference import exact_torque_free
    from xcheck.rotations import attitude_error

    q0, w0, duration = [0.7071067811865476, 0.7071067811865476, 0, 0], [0.02, 2.0, 0.03], 10.0
    m = mujoco.MjModel.from_xml_path(str(ROOT / "models" / "tumbler.xml"))
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    d = mujoco.MjData(m)
    d.qpos[3:7], d.qvel[3:6] = q0, w0
    q_exact, _ = exact_torque_free([1, 2, 3], q0, w0, np.array([0.0, duration]))
    lines, errors = [], {}
    with wp.ScopedDevice("cpu"):
        m.opt.timestep = 1 / 64
        t0 = time.perf_counter()
        mw, dw = mjw.put_model(m), mjw.put_data(m, d)
        mjw.step(mw, dw)
        first = time.perf_counter() - t0
        per_step = {}
        for nworld in (1, 1000):
            dw = mjw.put_data(m, d, nworld=nworld)
            mjw.step(mw, dw)
            t0 = time.perf_counter()
            for _ in range(50):
                mjw.step(mw, dw)
            wp.synchronize()
            per_step[nworld] = (time.perf_counter() - t0) / 50
        for dt in (1 / 64, 1 / 128, 1 / 256):
            m.opt.timestep = dt
            mw, dw = mjw.put_model(m), mjw.put_data(m, d)
            for _ in range(round(duration / dt)):
                mjw.step(mw, dw)
            errors[dt] = float(attitude_error(dw.qpos.numpy()[0][3:7].astype(float), q_exact[-1]))
    now = datetime.now(timezone.utc).strftime("%Y-%m-%d")
    from importlib.metadata import version

    lines += ["# MuJoCo Warp on this CPU", "",
              f"Made by `python benchmarks/warp_cpu.py --out docs/warp.md` on {now}: mujoco-warp "
              f"{version('mujoco-warp')}, warp-lang {version('warp-lang')}, MuJoCo {mujoco.__version__}, "
              f"{platform.processor() or platform.machine()}, on Warp's CPU device.", "",
              "**It runs, but it is not one of xcheck's engines:** on a CPU each step launches Warp's kernels one by "
              "one, and a step costs milliseconds whatever the number of worlds. A quick study of one bundled scenario "
              "(some 20 000 steps a method) would take minutes a method; MJX (docs/mjx.md) runs the same models "
              "in JAX at tens of microseconds a step.", "",
              "| what | measured |", "|---|---:|",
              f"| first step (its kernels compiled with LLVM, or loaded from Warp's cache: 14 s the first time here) | {first:.1f} s |",
              f"| one step, 1 world | {per_step[1] * 1e3:.1f} ms ({1 / per_step[1]:.0f} steps/s) |",
              f"| one step, 1000 worlds | {per_step[1000] * 1e3:.1f} ms ({1000 / per_step[1000]:.3g} body-steps/s) |"]
    for dt, e in errors.items():
        lines.append(f"| RK4 (float32) on the tumbler, attitude error at 10 s, dt = 1/{round(1 / dt)} s | {e:.2g} rad |")
    order = np.log2(errors[1 / 128] / errors[1 / 256])
    lines += ["", f"Its RK4's error falls by {2 ** order:.2g}x from 1/128 to 1/256 s (order {order:.2f}): float32's "
              "round-off already dominates at these steps, as in MJX's float32.", ""]
    text = "\n".join(lines)
    print(text)
    if args.out:
        Path(args.out).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
