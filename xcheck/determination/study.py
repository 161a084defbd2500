"""Attitude determination on a simulated run (issue 14): a magnetometer and a sun sensor read MuJoCo's
attitude, with noise; every method of :mod:`xcheck.determination.methods` estimates the attitude at every sample;
the estimates are compared with MuJoCo's attitude and with the error the noise predicts.

The set-up is a scenario's ``[determination]`` table (every key optional; see the README):

* ``method``, ``dt``: the run whose attitude is the truth (default ``mujoco-rk4`` at 1/64 s); every step is
  a sample.
* The magnetometer reads the scenario's field. Where the field is uniform, MuJoCo's own ``<magnetometer>``
  sensor (a site at the body's origin, ``opt.magnetic = mu0 H``) reads it on MuJoCo's states; otherwise the
  field model (:mod:`xcheck.fields`) in inertial components, rotated into the body by MuJoCo's attitude. A
  field given in body components has no inertial direction to determine an attitude from, and is refused.
* The sun sensor sees ``sun_direction`` (inertial, fixed) in the body frame.
* Noise levels ``[[determination.noise]]``: ``magnetometer_nT``, an isotropic Gaussian on the field vector
  [nT], and ``sun_deg``, a Gaussian angle about each axis perpendicular to the sun's direction [deg]; drawn
  from ``seed``. Each level's weights are ``1/sigma^2`` of each direction (the magnetometer's angular sigma is
  ``sigma_nT / |B|``), equal when the level is noise-free. TRIAD takes the more accurate sensor first.
* The approach study: the same run with the sun direction moved to ``approach_angles_deg`` from the field's at
  every sample, at the ``approach_noise`` level: how accuracy is lost as the two directions close up.

What is predicted: for the optimal methods (q-method, QUEST, SVD) the attitude error's covariance is, to first
order in the noise, Shuster's ``P = [sum_k sigma_k^-2 (I - b_k b_k^T)]^-1`` (the Cramér-Rao bound of the
measurement model above); the RMS error over the run should be ``sqrt(mean tr P)``. TRIAD's is larger.
"""

from __future__ import annotations

import time

import numpy as np

from ..rotations import attitude_error, quat_to_dcm
from . import methods as det
from .sensors import (
    DEFAULT_SPEC,
    EXACT_TOL,
    MU0,
    PREDICTION_BAND,
    DeterminationSpec,
    observe,
    predicted_rms,
)

__all__ = ["run_determination", "summary_lines"]


def _stats(err) -> dict:
    return {"mean": float(np.mean(err)), "rms": float(np.sqrt(np.mean(err**2))),
            "p95": float(np.percentile(err, 95)), "max": float(np.max(err))}


# --------------------------------------------------------------------------------------------------------
# the study
# --------------------------------------------------------------------------------------------------------
def _truth_and_field(scenario, spec):
    """MuJoCo's run (t, q) and the field: (B_body from the magnetometer, B_world, source text)."""
    from ..engines import ENGINES
    from ..runners import RUNNERS
    from ..study.context import run_context

    ctx = run_context(scenario)
    field = getattr(ctx.torque, "field", None)
    if field is None:
        raise det.DeterminationError(
            f"{scenario.path}: [determination]: the scenario has no magnetic field ([torque] kind = \"magnetic\"), "
            "so there is nothing for a magnetometer to read")
    if field.frame != "world":
        raise det.DeterminationError(
            f"{scenario.path}: [determination]: the field {field.name!r} is given in body components; a "
            "magnetometer then has no inertial reference direction to determine an attitude from (use a field "
            "given in inertial components: uniform, orbit-dipole, igrf, world-table)")
    traj = RUNNERS[spec.method].run(ctx, spec.dt)
    if traj.status != "ok":
        raise det.DeterminationError(f"{scenario.path}: [determination]: the truth run failed: {traj.message}")
    B_world = MU0 * field.strength(traj.t)
    R = quat_to_dcm(traj.q)
    engine = ENGINES.get(RUNNERS[spec.method].engine)  # None: ours
    if engine is not None and engine.magnetometer and field.frame == "world" and not field.time_dependent:
        import importlib

        function, source = engine.magnetometer  # the engine's own sensor reads a field fixed in the world
        B_body = getattr(importlib.import_module(engine.module), function)(scenario.model, traj.q, B_world[0])
    else:
        B_body = np.einsum("tji,tj->ti", R, B_world)
        source = f"xcheck's field model ({field.describe()}) rotated into the body by the run's attitude"
    return traj, R, B_world, B_body, source


def run_determination(scenario, spec: DeterminationSpec | None = None) -> tuple[dict, dict]:
    """Run the determination study of ``scenario`` (its ``[determination]``, else the defaults): returns
    ``(data, series)``: ``data`` JSON-able (stats per level and method, the approach study, checks,
    ``passed``), ``series`` the per-sample errors for figures."""
    spec = spec or getattr(scenario, "determination", None) or DEFAULT_SPEC
    traj, R, B_world, B_body, source = _truth_and_field(scenario, spec)
    T = len(traj.t)
    sun_world = np.broadcast_to(np.asarray(spec.sun_direction, float), (T, 3))
    B_hat = B_world / np.linalg.norm(B_world, axis=-1, keepdims=True)
    angle = np.degrees(np.arccos(np.clip(np.sum(B_hat * sun_world, axis=-1), -1, 1)))
    rng = np.random.default_rng(spec.seed)
    levels, series, checks = [], {"t": traj.t, "levels": {}}, []
    for level in spec.levels:
        row = {"name": level.name, "magnetometer_nT": level.magnetometer_nT, "sun_deg": level.sun_deg,
               "first": None, "predicted_rms": None, "methods": {}}
        try:
            first, pred, solved = _solve(level, sun_world, B_body, B_world, R, traj.q, spec.methods, rng)
        except UNDETERMINABLE as exc:  # geometry only the run knows (a field that turns onto the sun's
            # direction): this level fails its check; the rest of the report stands
            checks.append(_undeterminable(f"{level.name}: an attitude at every sample", exc))
            levels.append(row)
            series["levels"][level.name] = {"errors": {}, "predicted_rms": None}
            continue
        row.update(first=first, predicted_rms=pred)
        errs = {}
        for m, (err, near, seconds) in solved.items():
            errs[m] = err
            row["methods"][m] = {**_stats(err), "near_degenerate": near,
                                 "solutions_per_second": T / seconds if seconds > 0 else None,
                                 "ratio_to_predicted": None if pred is None else float(np.sqrt(np.mean(err**2)) / pred)}
            if level.noise_free:
                worst = float(err.max())
                checks.append({"name": f"{m}, {level.name}: the truth recovered", "passed": worst <= EXACT_TOL,
                               "text": f"largest error {worst:.2e} rad (limit {EXACT_TOL:g})"})
            elif m != "triad":
                ratio = row["methods"][m]["ratio_to_predicted"]
                lo, hi = PREDICTION_BAND
                checks.append({"name": f"{m}, {level.name}: RMS error as predicted", "passed": lo <= ratio <= hi,
                               "text": f"RMS {row['methods'][m]['rms']:.3e} rad, predicted {pred:.3e} rad "
                                       f"(ratio {ratio:.3f}, band {lo:g}-{hi:g})"})
        levels.append(row)
        series["levels"][level.name] = {"errors": errs, "predicted_rms": pred}
    approach = None
    if spec.approach_noise:
        try:
            approach = _approach(spec, traj, R, B_body, B_world, rng)
        except UNDETERMINABLE as exc:
            checks.append(_undeterminable("the approach study", exc))
    data = {"scenario": scenario.name, "truth": {"method": spec.method, "dt": spec.dt, "samples": T,
                                                 "duration": float(traj.t[-1])},
            "magnetometer": source, "sun_direction": list(spec.sun_direction),
            "angle_deg": {"min": float(angle.min()), "mean": float(angle.mean()), "max": float(angle.max())},
            "seed": spec.seed, "methods": list(spec.methods), "levels": levels, "approach": approach,
            "checks": checks, "passed": all(c["passed"] for c in checks)}
    return data, series


#: What a sample the run made undeterminable raises: the solvers' refusal, or the prediction's singular matrix.
UNDETERMINABLE = (det.DeterminationError, np.linalg.LinAlgError)


def _undeterminable(name: str, exc) -> dict:
    """The failed check of a part of the study that cannot be solved along this run, with the reason."""
    why = ("the predicted error's information matrix is singular (the two directions are parallel)"
           if isinstance(exc, np.linalg.LinAlgError) else str(exc))
    return {"name": name, "passed": False, "text": f"not determinable along this run: {why}"}


def _approach(spec, traj, R, B_body, B_world, rng) -> dict:
    """The approach study: the sun placed ``angle`` from the field's direction at every sample."""
    level = next(lv for lv in spec.levels if lv.name == spec.approach_noise)
    h = B_world / np.linalg.norm(B_world, axis=-1, keepdims=True)
    axis = np.where(np.abs(h[:, 2:3]) < 0.9, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
    p = np.cross(h, axis)
    p /= np.linalg.norm(p, axis=-1, keepdims=True)
    out = {"level": level.name, "angles_deg": list(spec.approach_angles_deg), "predicted_rms": [],
           "methods": {m: {"rms": [], "near_degenerate": []} for m in spec.methods}}
    for a in spec.approach_angles_deg:
        th = np.radians(a)
        _, pred, solved = _solve(level, np.cos(th) * h + np.sin(th) * p, B_body, B_world, R, traj.q, spec.methods,
                                 rng)
        out["predicted_rms"].append(pred)
        for m, (err, near, _) in solved.items():
            out["methods"][m]["rms"].append(float(np.sqrt(np.mean(err**2))))
            out["methods"][m]["near_degenerate"].append(near)
    return out


def _solve(level, sun_world, B_body, B_world, R, q_true, methods, rng):
    """One noise level's observations, solved by every method: ``(first sensor, predicted RMS (None when
    noise-free), {method: (errors against q_true, near-degenerate count, seconds)})``."""
    b, r, w, sig, first = observe(B_body, B_world, sun_world, R, level, rng)
    pred = None
    if not level.noise_free:
        pred = float(np.sqrt(np.mean(predicted_rms(np.einsum("tji,tkj->tki", R, r), sig) ** 2)))
    solved = {}
    for m in methods:
        det.determine(m, b[:2], r[:2], w[:2])  # compiled code loaded before the timing
        t0 = time.perf_counter()
        est = det.determine(m, b, r, w)
        seconds = time.perf_counter() - t0
        solved[m] = (attitude_error(est.q, q_true), int(np.sum(est.near_degenerate)), seconds)
    return first, pred, solved


def summary_lines(data: dict) -> list[str]:
    """A determination study as text (``xcheck determine``): the statistics per noise level and method, the checks, the approach."""
    tr = data["truth"]
    lines = [f"attitude determination on {data['scenario']}: truth {tr['method']} every {tr['dt']:g} s "
             f"({tr['samples']} samples); magnetometer: {data['magnetometer']}",
             f"sun direction {[round(x, 4) for x in data['sun_direction']]}, {data['angle_deg']['min']:.1f}-"
             f"{data['angle_deg']['max']:.1f} deg from the field; noise seed {data['seed']}", "",
             f"{'noise':16s} {'method':9s} {'RMS [rad]':>10s} {'predicted':>10s} {'ratio':>6s} {'max [rad]':>10s} "
             f"{'near-deg.':>9s} {'solutions/s':>11s}"]
    for lv in data["levels"]:
        for m, s in lv["methods"].items():
            pred = "-" if lv["predicted_rms"] is None else f"{lv['predicted_rms']:.3e}"
            ratio = "-" if s["ratio_to_predicted"] is None else f"{s['ratio_to_predicted']:.3f}"
            rate = f"{s['solutions_per_second']:.3g}" if s["solutions_per_second"] else "-"
            lines.append(f"{lv['name']:16s} {m:9s} {s['rms']:10.3e} {pred:>10s} {ratio:>6s} {s['max']:10.3e} "
                         f"{s['near_degenerate']:9d} {rate:>11s}")
    ap = data.get("approach")
    if ap:
        lines += ["", f"approach ({ap['level']}): RMS error [rad] against the angle between the two directions",
                  f"{'angle [deg]':>11s} {'predicted':>10s} " + " ".join(f"{m:>10s}" for m in ap["methods"])]
        for i, a in enumerate(ap["angles_deg"]):
            lines.append(f"{a:11g} {ap['predicted_rms'][i]:10.3e} "
                         + " ".join(f"{v['rms'][i]:10.3e}" for v in ap["methods"].values()))
    failed = [c for c in data["checks"] if not c["passed"]]
    lines += ["", f"checks: {len(data['checks']) - len(failed)} of {len(data['checks'])} passed"]
    lines += [f"  FAILED {c['name']}: {c['text']}" for c in failed]
    return lines
