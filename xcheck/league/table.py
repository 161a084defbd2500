"""The league table: the boxes benchmark's published figures (ODE, Bullet, Simbody, DART) beside MuJoCo's four
integrators and ours, at the benchmark's steps; as report blocks (a :class:`~xcheck.report.render.Section`), as
``docs/league.md`` (``xcheck league --out``), and as a figure (errors against the step, every engine)."""

from __future__ import annotations

import math
from datetime import datetime, timezone

import numpy as np

from ..report.render import fmt
from . import boxes as B

#: What a fourth-order method (MuJoCo's RK4, ours) must keep at the benchmark's steps: the relative momentum and
#: energy errors (measured: at most 4e-11 at 1e-3 s, 2e-10 at 1e-4 s, where round-off of 1e5 steps dominates)
FOURTH_ORDER_BOUND = 1e-8
ENGINE_NAMES = {"ode": "ODE", "bullet": "Bullet", "simbody": "Simbody", "dart": "DART"}


def slope(rows, key: str) -> float | None:
    """The error's order in the step: the least-squares slope of log(error) on log(dt) over the rows with an error
    above round-off (1e-12); None with fewer than two such."""
    pts = [(math.log(r["dt"]), math.log(r[key])) for r in rows if r[key] is not None and r[key] > 1e-12]
    if len(pts) < 2 or len({p[0] for p in pts}) < 2:
        return None
    x, y = np.array(pts).T
    return float(np.polyfit(x, y, 1)[0])


def entries(rows: list[dict], case: str, steps) -> list[dict]:
    """One entry per engine method on ``case``: its rows at ``steps`` (ours and MuJoCo's from ``rows``, the
    published engines' from their CSV), ranked by the relative momentum error at the coarsest step."""
    published = [r for r in B.published() if r["case"] == case and any(math.isclose(r["dt"], s) for s in steps)]
    groups: dict = {}
    for r in published:
        groups.setdefault(("published", ENGINE_NAMES[r["engine"]]), []).append(r)
    for r in rows:
        if r["case"] == case and any(math.isclose(r["dt"], s) for s in steps):
            groups.setdefault((r["engine"], r["method"]), []).append(r)
    out = []
    for (source, name), rs in groups.items():
        rs = sorted(rs, key=lambda r: r["dt"])
        out.append({"source": source, "name": name, "rows": rs, "order": slope(rs, "momentum_error")})
    coarsest = max(steps)
    return sorted(out, key=lambda e: (next((r["momentum_error"] for r in e["rows"]
                                            if math.isclose(r["dt"], coarsest)), math.inf), e["name"]))


def _who(e) -> str:
    return {"published": f"{e['name']} (published)", "xcheck": f"{e['name']} (ours)"}.get(e["source"], e["name"])


def table_rows(rows, case: str, steps) -> tuple[list[str], list[list[str]]]:
    """Header and rows of one case's league table at ``steps`` (finest and coarsest shown, plus the orders)."""
    shown = sorted({min(steps), max(steps)})
    head = ["rank", "engine / integrator"]
    for key, what in (("momentum_error", "‖ΔH‖/‖H₀‖"), ("energy_error", "‖ΔE‖/E₀")):
        head += [f"{what} at {dt:g} s" for dt in shown]
    head += [f"position error at {max(steps):g} s [m]", f"attitude error at {max(steps):g} s [rad]"]
    if len(steps) > 1:
        head.append("order of ‖ΔH‖")
    body = []
    for k, e in enumerate(entries(rows, case, steps), 1):
        at = {round(r["dt"], 6): r for r in e["rows"]}
        line = [str(k), _who(e)]
        for key in ("momentum_error", "energy_error"):
            line += [fmt(at[round(dt, 6)][key], ".3g") if round(dt, 6) in at else "—" for dt in shown]
        last = at.get(round(max(steps), 6), {})
        position = last.get("position_error")
        line.append("exact (attitude only)" if e["source"] == "xcheck" else fmt(position, ".3g"))
        line.append(fmt(last.get("attitude_error"), ".3g") if e["source"] != "published" else "—")
        if len(steps) > 1:
            line.append("—" if e["order"] is None else f"{e['order']:.2f}")
        body.append(line)
    return head, body


def checks(rows) -> list[tuple[str, bool, str]]:
    """The league's checks: every fourth-order method (MuJoCo's RK4 and ours) within :data:`FOURTH_ORDER_BOUND`
    of the benchmark's invariants at every step, every case."""
    out = []
    for r in rows:
        if r["method"] == "mujoco-rk4" or r["engine"] == "xcheck":
            worst = max(r["momentum_error"], r["energy_error"])
            out.append((f"{r['case']} / {r['method']} at {r['dt']:g} s", worst <= FOURTH_ORDER_BOUND,
                        f"largest relative invariant error {worst:.2g} (bound {FOURTH_ORDER_BOUND:g})"))
    return out


def summary(rows) -> str:
    """One sentence: where MuJoCo's integrators stand among the published engines on the complex case."""
    coarsest = max(r["dt"] for r in rows)
    at = {r["method"]: r for r in rows if r["case"] == "complex" and math.isclose(r["dt"], coarsest)}
    pub = {ENGINE_NAMES[r["engine"]]: r for r in B.published()
           if r["case"] == "complex" and math.isclose(r["dt"], coarsest)}
    if "mujoco-rk4" not in at or "mujoco-euler" not in at:
        return ""
    best = min(pub.values(), key=lambda r: r["momentum_error"])
    best_name = next(k for k, v in pub.items() if v is best)
    return (f"On the boxes benchmark's tumbling box at {coarsest:g} s, MuJoCo's RK4 keeps the angular momentum to "
            f"{at['mujoco-rk4']['momentum_error']:.1g} (relative), "
            f"{math.floor(math.log10(best['momentum_error'] / at['mujoco-rk4']['momentum_error']))} orders of magnitude "
            f"better than the best published engine ({best_name}, {best['momentum_error']:.3g}); its Euler "
            f"({at['mujoco-euler']['momentum_error']:.3g}) sits with ODE and Bullet.")


def live_engines_text(live) -> str:
    """What the live engines' rows are (issue 40), for the docs' table and the report's section."""
    return ("Live engines (run here, translation and gravity included, as MuJoCo is): " + ", ".join(live) + ". "
            "pybullet-maximal is Bullet's btRigidBody (its implicit gyroscopic term), pybullet-multibody its "
            "btMultiBody, both with no damping; pybullet-multibody-default is the multibody as createMultiBody makes "
            "it, with its angular damping of 0.04. What changed since 2015: today's Bullet lands on the published "
            "Bullet figures through its maximal path and on ODE's through its multibody: the published \"Bullet\" "
            "and \"ODE\" are these two first-order schemes. dart-semi-implicit-euler is DART's World today: it lands "
            "on ODE's figures too, where DART's published momentum error was about 2 (200 %). Drake was not in the "
            "2015 benchmark: drake-semi-explicit-euler (its MultibodyPlant in continuous time) lands on ODE's "
            "figures as well, and drake-rk3 keeps the momentum to about 1e-7 but the attitude only to about 4e-3 "
            "rad at 1e-3 s, where MuJoCo's RK4 keeps it to 1e-10: Drake integrates the quaternion additively. "
            "EXUDYN was not in it either: exudyn-rk44 on its Lie group node (RKMK4) keeps the momentum to about 3e-11 "
            "and the attitude to 2e-10 rad at 1e-3 s, with MuJoCo's RK4; its implicit exudyn-generalized-alpha, "
            "second order, to about 7e-6.")


def markdown(rows, steps, *, version: str, versions: dict, command: str) -> str:
    """``docs/league.md``: both cases' tables, every step's figures in an appendix, the source, what was matched."""
    now = datetime.now(timezone.utc).strftime("%Y-%m-%d")
    lines = [
        "# The league table: MuJoCo, the engines installed here and xcheck on the boxes benchmark",
        "",
        f"Made by `{command}` on {now} with xcheck {version} "
        f"({', '.join(f'{k} {v}' for k, v in versions.items())}); do not edit by hand.",
        "",
        f"**Source of the published figures:** {B.SOURCE}. A box of 10 kg, 0.1 × 0.4 × 0.9 m, 10 s from the "
        "identity; *simple*: no gravity, ω₀ = [0.5, 0, 0] rad/s about the major axis; *complex*: gravity "
        "[0, 0, −9.8] m/s², v₀ = [−2, 2, 8] m/s, ω₀ = [0.1, 5, 0.1] rad/s, close to the intermediate axis, so that it "
        "tumbles.",
        "",
        "**The metrics, as theirs** (`boxes.cc`, `boxes_description.ipynb`): the largest **relative** angular momentum "
        "error |H(t) − H₀|/|H₀| (H about the centre of mass, world components) and the largest relative energy error "
        "|E(t) − E₀|/E₀ (E = ½m|v|² + ½ωᵀIω − m g·c) over the states after each of ⌈10/Δt⌉ steps; both are "
        "dimensionless (the issue's kg·m²/s and J are not their units). MuJoCo flies the whole body, translation "
        "included, checked as theirs were (position error: the largest distance from the exact parabola). **Ours "
        "are attitude-only**: their centre of mass is the exact parabola, so their energy error is the rotational "
        "energy's over the same E₀. The attitude error is xcheck's own metric, against the exact (Jacobi elliptic) "
        "solution at the end of the run; the published engines did not report it for the complex case.",
        "",
    ]
    for case in B.CASES.values():
        head, body = table_rows(rows, case.name, steps)
        lines += [f"## {case.name.capitalize()}: {case.what}", "", "| " + " | ".join(head) + " |",
                  "|" + "|".join("---" if k < 2 else "---:" for k in range(len(head))) + "|"]
        lines += ["| " + " | ".join(r) + " |" for r in body]
        lines.append("")
    live = sorted({r["method"] for r in rows if r["engine"] not in ("mujoco", "xcheck")})
    if live:  # issue 40: the engines people choose, run here beside the published figures
        lines += [live_engines_text(live), ""]
    text = summary(rows)
    if text:
        lines += ["## In words", "", text, "",
                  "MuJoCo's Euler reproduces ODE's figures to three digits and its implicit and implicitfast reproduce "
                  "Bullet's, all three with semi-implicit Euler's centre of mass error g Δt T/2 = 0.049 m at 1e-3 s: "
                  "as if they took the same steps (MuJoCo's implicit ones linearise the gyroscopic term, its Euler "
                  "keeps it explicit). Simbody's published figures at each step are ODE's at half that step, to six "
                  "digits. DART's momentum error of about 2 (200 %) at every step is the published figure, not a "
                  "typo of ours.", ""]
    lines += ["## Every step", "", "| case | engine / integrator | Δt [s] | ‖ΔH‖/‖H₀‖ | ‖ΔE‖/E₀ | position error [m] |",
              "|---|---|---:|---:|---:|---:|"]
    for case in B.CASES:
        for e in entries(rows, case, steps):
            for r in e["rows"]:
                pos = "exact" if e["source"] == "xcheck" else fmt(r.get("position_error"), ".3g")
                lines.append(f"| {case} | {_who(e)} | {r['dt']:g} | {fmt(r['momentum_error'], '.3g')} | "
                             f"{fmt(r['energy_error'], '.3g')} | {pos} |")
    lines.append("")
    return "\n".join(lines)


FIGURE = "boxes-league.png"


def draw(rows, steps) -> tuple[str, str, bytes]:
    """The complex case's relative momentum and energy errors against the step, every engine: ``(file, caption,
    png)``."""
    from ..report.plots import colors_of, png_of, subplots

    fig, axes = subplots(1, 2, size=(13, 4.8), legend_outside=True)
    fig.subplots_adjust(wspace=0.28)
    drawn = [e for e in entries(rows, "complex", steps)  # ours lie on one line at round-off: one stands for them
             if not (e["source"] == "xcheck" and e["name"] != "lie-rkmk4")]
    colors = colors_of([_who(e) for e in drawn])  # 20 colours: the default cycle's 10 repeated with 17 lines
    for e in drawn:
        rs = e["rows"]
        style = {"published": ":", "mujoco": "--", "xcheck": "-"}.get(e["source"], "-.")  # live engines: dash-dot
        marker = {"published": "s", "mujoco": "o", "xcheck": "^"}.get(e["source"], "d")
        for ax, key in zip(axes, ("momentum_error", "energy_error")):
            dts = [r["dt"] for r in rs]
            ys = [max(r[key], 1e-17) for r in rs]
            ax.loglog(dts, ys, style, marker=marker, color=colors[_who(e)],
                      label=_who(e) + (" (and all ours)" if e["source"] == "xcheck" else ""))
    for ax, what in zip(axes, ("relative angular momentum error ‖ΔH‖/‖H₀‖", "relative energy error ‖ΔE‖/E₀")):
        ax.set_xlabel("step Δt [s]")
        ax.set_ylabel(what)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_title("Boxes, complex case: angular momentum")
    axes[1].set_title("Boxes, complex case: energy")
    axes[1].legend(fontsize=8, loc="center left", bbox_to_anchor=(1.02, 0.5))
    caption = ("The boxes benchmark's complex case (a box tumbling near its intermediate axis, 10 s): the largest "
               "relative angular momentum and energy errors against the step, the published engines (dotted) beside "
               "MuJoCo's integrators (dashed), the engines installed here (dash-dot, live) and ours (solid, one line "
               "for all: they agree to round-off)")
    return png_of(fig, FIGURE, caption)


def section(rows, steps):
    """The report's League section (a :class:`~xcheck.report.render.Section`): both cases' tables at ``steps``, the
    figure when there are several, the fourth-order checks; its verdict joins the report's."""
    from ..report.document import Cell, Figure, Heading, Para, Table
    from ..report.render import Section

    results = checks(rows)
    ok = all(c[1] for c in results)
    blocks = [Heading(2, "League table: the boxes benchmark", anchor="league",
                      badge=("PASSED", "pass") if ok else ("FAILED", "fail")),
              Para(f"MuJoCo's four integrators (the whole body, translation included) and ours (attitude only) on the "
                   f"boxes benchmark, beside the figures it published for ODE, Bullet, Simbody and DART ({B.SOURCE}). "
                   "Errors are relative and dimensionless, as theirs: the largest ‖ΔH‖/‖H₀‖ and ‖ΔE‖/E₀ over 10 s. "
                   f"At {', '.join(f'{s:g}' for s in sorted(steps))} s here; every step from 1e-4 to 1e-3 s: "
                   "`xcheck league` (docs/league.md).")]
    live = sorted({r["method"] for r in rows if r["engine"] not in ("mujoco", "xcheck")})
    if live:  # issue 40: the engines people choose, run live beside the published figures
        blocks.append(Para(live_engines_text(live)))
    text = summary(rows)
    if text:
        blocks.append(Para(text))
    for case in B.CASES.values():
        head, body = table_rows(rows, case.name, steps)
        blocks.append(Heading(3, f"Boxes, {case.name}: {case.what}"))
        blocks.append(Table(head, [[Cell(c, num=k != 1) for k, c in enumerate(r)] for r in body]))
    figures = []
    if len(steps) > 1:
        figures.append(draw(rows, steps))
        blocks.append(Figure(figures[-1][0], figures[-1][1]))
    blocks.append(Table(["check", "result"], [[Cell(what, "pass" if passed else "fail"), why]
                                              for what, passed, why in results],
                        fold=f"{sum(c[1] for c in results)} of {len(results)} fourth-order runs within "
                             f"{FOURTH_ORDER_BOUND:g} of the invariants"))
    return Section(blocks=blocks, figures=figures, results={"league": {"steps": list(steps), "rows": rows,
                                                                       "passed": ok}},
                   passed=ok)  # no first-screen sentence: the nightly's History has that place
