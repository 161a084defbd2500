"""What float32 costs (issue 29): MJX's integrators in float32 and float64 on every bundled scenario, beside MuJoCo's
RK4 and ours, each one's error floor against the reference and the largest step within the step-size table's
tolerances (1e-3, 1e-6, 1e-9 rad), and MJX's batched steps per second on this CPU beside ours: ``xcheck mjx``,
``docs/mjx.md``."""

from __future__ import annotations

from datetime import datetime, timezone

from ..report.render import fmt

#: Beside MJX's six: MuJoCo's RK4 (the same model in C, float64) and our reference-grade method (the study's floor)
BESIDE = ("mujoco-rk4", "lie-rkmk4")
TOLERANCES = ("1e-03", "1e-06", "1e-09")


def mjx_methods() -> list[str]:
    from ..runners import RUNNERS

    return [m for m, r in RUNNERS.items() if r.engine == "mjx"]


def run_precision_studies(scenarios=None, *, methods=None, quick: bool = True, workers: int | None = None,
                          progress=None):
    """The studies: every bundled scenario (or ``scenarios``) with MJX's methods (or ``methods``) and :data:`BESIDE`."""
    import dataclasses

    from ..scenario import bundled_scenarios, resolve_scenario
    from ..study import run_studies

    chosen = [dataclasses.replace(sc, methods=[*(methods or mjx_methods()), *BESIDE])
              for sc in (resolve_scenario(n) for n in (scenarios or bundled_scenarios()))]
    return run_studies(chosen, quick=quick, workers=workers, progress=progress)


def floors(studies) -> list[dict]:
    """Per scenario and method: the observed order, its finest-step error (the floor, for float32) and the largest
    step within each tolerance (None: never within it at the study's steps)."""
    rows = []
    for st in studies:
        for name, m in st.data["methods"].items():
            errors = [r["attitude_error"] for r in m["runs"] if r["attitude_error"] is not None]
            rows.append({"scenario": st.name, "method": name, "expected": m["expected_order"],
                         "observed": m["observed_order"], "floor": min(errors) if errors else None,
                         "within": {tol: (m.get("largest_step_within") or {}).get(tol) for tol in TOLERANCES},
                         "verdict": m["verdict"]})
    return rows


def markdown(rows, bench, *, version: str, versions: dict, command: str) -> str:
    """``docs/mjx.md``: the floors per scenario, the summary per method, the benchmark rows."""
    now = datetime.now(timezone.utc).strftime("%Y-%m-%d")
    methods = list(dict.fromkeys(r["method"] for r in rows))
    lines = ["# MJX: what float32 costs", "",
             f"Made by `{command}` on {now} with xcheck {version} ({', '.join(f'{k} {v}' for k, v in versions.items())});"
             " do not edit by hand. MJX (MuJoCo's JAX port, PyPI `mujoco-mjx`) on JAX's CPU backend, in float32 (JAX's "
             "default) and float64 (`-x64`: `jax_enable_x64`), on every bundled scenario at its quick steps, against "
             "the exact or DOP853 reference. MJX has no control callback: an applied torque (and a motor's command) "
             "is taken at each step's start and held over it, first order, as the study expects.", ""]
    summary = []
    for m in methods:
        mine = [r for r in rows if r["method"] == m]
        if not mine:
            continue
        best = min((r["floor"] for r in mine if r["floor"] is not None), default=None)
        worst = max((r["floor"] for r in mine if r["floor"] is not None), default=None)
        reach = {tol: sum(r["within"][tol] is not None for r in mine) for tol in TOLERANCES}
        summary.append([m, f"{fmt(best, '.2g')} … {fmt(worst, '.2g')}",
                        *(f"{reach[tol]} of {len(mine)}" for tol in TOLERANCES)])
    lines += ["## The floors, in brief", "",
              "The smallest error a method reached on a scenario (at its finest quick step: for float32, its floor), "
              "the range over the bundled scenarios, and on how many scenarios some step of the study was within each "
              "of the step-size table's tolerances.", "",
              "| method | smallest error at the finest step [rad] | within 1e-3 rad | within 1e-6 rad | within 1e-9 rad |",
              "|---|---:|---:|---:|---:|"]
    lines += ["| " + " | ".join(r) + " |" for r in summary]
    lines += ["", "## Per scenario", "",
              "| scenario | method | expected order | observed | error at the finest step [rad] | largest step within "
              "1e-3 rad [s] | 1e-6 rad | 1e-9 rad |", "|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['scenario']} | {r['method']} | {fmt(r['expected'], 'd')} | {fmt(r['observed'], '.2f')} | "
                     f"{fmt(r['floor'], '.2g')} | " + " | ".join(fmt(r["within"][t], ".3g") for t in TOLERANCES) + " |")
    if bench:
        lines += ["", "## Steps per second on this CPU", "",
                  "`xcheck bench --quick --with mjx` rows, best of 2: MJX's RK4 on one body (torque free, and with "
                  "RAX-1's orbit field held through the host callback) and batched (`jax.vmap` over 1000 "
                  "gyroscopes), beside our batch path (1000 gyroscopes), a sweep's cells and MuJoCo's own `mj_step` "
                  "loop (one body).", "",
                  "| method | scenario | batch | body-steps per second |", "|---|---|---:|---:|"]
        for row in bench:
            lines.append(f"| {row['method']} | {row['scenario']} | {row['batch']} | {row['steps_per_second']:.3g} |")
    lines.append("")
    return "\n".join(lines)
