"""The report's horizon section (issue 41; ``xcheck report --horizon``): every reported scenario with a ``[horizon]``
table run over its long duration (:func:`xcheck.study.horizon.run_horizon`), each method at its steps, and for each
method and step the verdict the issue asks for: how long it stays within 1e-6 and 1e-3 rad, its error's growth law
and its energy's. Opt-in, not in every full report: the bundled horizons take three or four minutes on two cores,
where the full report's goal is three seconds a scenario (docs/decisions.md)."""

from __future__ import annotations

from ..study.horizon import (THRESHOLDS, change_texts, default_steps, horizon_methods, horizon_plan, momentum_heading,
                             run_horizon, within_text)

__all__ = ["horizon_job", "horizon_section", "start_horizons", "with_horizon", "PARTS"]


def with_horizon(scenarios) -> list:
    """The scenarios that declare a ``[horizon]`` table."""
    return [sc for sc in scenarios if sc.horizon is not None]


#: Each scenario's horizon is run in this many parts (its methods dealt out in turn), so that both processes of a
#: two-core report work on the longest tasks (:func:`start_horizons`).
PARTS = 2


def horizon_job(scenario, methods=None) -> tuple[dict, str | None]:
    """One scenario's horizon study of ``methods`` (default: :func:`~xcheck.study.horizon.horizon_methods`; a part of
    them, named by this process: a worker's registry may list the engines in another order): ``(xcheck.horizon/2
    document, why it could not run)``; the reference refused over the duration is the second (the document then names
    the scenario alone)."""
    import time

    from ..reference import ReferenceFailure

    duration = scenario.horizon[0]
    t0 = time.perf_counter()
    try:
        res = run_horizon(scenario, duration=duration, steps=default_steps(scenario, duration), methods=methods)
    except ReferenceFailure as exc:
        return {"scenario": scenario.name, "duration": duration}, str(exc)
    return res.to_json() | {"wall_time": time.perf_counter() - t0}, None


def start_horizons(scenarios, pool, progress=None) -> tuple:
    """The ``[horizon]`` scenarios, the pool their studies will run in and the progress bar's callback: ``(scenarios,
    pool, progress)``. Nothing is submitted
    yet: queued before the studies, the horizons (the report's longest tasks) kept the pool's worker while the
    studies waited behind them, and this process idle; they start once the studies are in (:func:`horizon_section`)."""
    return with_horizon(scenarios), pool, progress


def _gather(scenarios, pool, progress=None) -> dict:
    """Every part's result by ``(scenario name, part)``, each scenario in :data:`PARTS` parts: all submitted to
    ``pool``, then those not yet begun there taken back and run here from the last (the worker takes them from the
    first), then the rest waited for. Without a pool, each scenario whole, here."""
    def tick(what):
        if progress:
            progress(len(done), total, what)

    done: dict = {}
    if pool is None:
        total = len(scenarios)
        for sc in scenarios:
            tick(f"horizon of {sc.name}")
            done[sc.name, 0] = horizon_job(sc)
        tick("")
        return done
    methods = horizon_methods()
    flat = [(sc, k, pool.submit(horizon_job, sc, methods[k::PARTS])) for sc in scenarios for k in range(PARTS)]
    total = len(flat)
    for sc, k, job in reversed(flat):
        if job.cancel():  # not begun in the pool: this process takes it
            tick(f"horizon of {sc.name} ({k + 1} of {PARTS})")
            done[sc.name, k] = horizon_job(sc, methods[k::PARTS])
    for sc, k, job in flat:
        if (sc.name, k) not in done:
            tick(f"horizon of {sc.name} ({k + 1} of {PARTS})")
            done[sc.name, k] = job.result()
    tick("")
    return done


def _finish(scenario, parts: list) -> tuple[dict, tuple | None, str | None]:
    """One scenario's parts joined, its lines in the methods' order, and its figure drawn: ``(document, figure, why
    not run)``."""
    from .plots import horizon_figure, png_of

    refused = [why for _, why in parts if why]
    if refused:
        return parts[0][0], None, refused[0]
    doc = dict(parts[0][0])
    order = {m: k for k, m in enumerate(horizon_methods())}
    doc["lines"] = sorted((line for d, _ in parts for line in d["lines"]), key=lambda x: (order[x["method"]], -x["dt"]))
    doc["wall_time"] = sum(d["wall_time"] for d, _ in parts)
    import dataclasses


    long = dataclasses.replace(scenario, duration=doc["duration"])  # what was left out, said once for all the parts
    doc["left_out"] = horizon_plan(long, horizon_methods(), doc["steps"], doc["duration"])[1]
    figure = png_of(horizon_figure(doc), f"{scenario.name}-horizon.png",
                    f"{scenario.name} over {doc['duration']:g} s: the attitude error against time on log-log axes, one "
                    "panel per step, each method a line (dotted: 1e-6 and 1e-3 rad); below, the energy's drift where "
                    "the motion keeps one")
    return doc, figure, None


def horizon_section(started) -> "object | None":
    """The section of the horizon studies (:func:`start_horizons`' scenarios, run now), None without any."""
    from ..runners import RUNNERS
    from .document import Cell, Figure, Heading, Para, Table
    from .render import Section

    scenarios, pool, progress = started
    done = _gather(scenarios, pool, progress)
    results = [_finish(sc, [done[key] for key in sorted(k for k in done if k[0] == sc.name)]) for sc in scenarios]
    if not results:
        return None
    refused = [(doc["scenario"], why) for doc, _, why in results if why]
    # ours must run over every bundled horizon (an engine's method may fail: MuJoCo's Euler blows up on the top)
    failed = [(doc["scenario"], line["method"], line["dt"]) for doc, _, why in results if not why
              for line in doc["lines"] if line["status"] != "ok" and RUNNERS[line["method"]].engine == "xcheck"]
    ok = not refused and not failed
    blocks = [Heading(2, "Horizons: how long each method can be trusted", anchor="horizons",
                      badge=("PASSED", "pass") if ok else ("FAILED", "fail")),
              Para("Each scenario with a [horizon] table over its long duration, each method at its steps, against the "
                   "scenario's reference at every sampled time (the closed form, or the compiled DOP853 at rtol "
                   "2.5e-15 checked against itself at half the tolerance). For each method and step: the attitude "
                   "error at the end, its growth law error ∝ tᵖ (Runge-Kutta methods: p from 1 toward 2 as the phase "
                   "error takes over; the symplectic splittings and the variational integrator: 1, a phase error "
                   "alone), the largest change of each invariant the motion keeps, signed (the energy's and |L|'s relative: + "
                   "gained, − damped; the angle L's direction turned), with its law (gains or damps ∝ t or tᵠ, a "
                   "bounded oscillation, or round-off), and "
                   "the verdict: how long it stays within 1e-6 and 1e-3 rad. The same as xcheck horizon SCENARIO.")]
    figures = []
    for doc, figure, why in results:
        blocks.append(Heading(3, f"{doc['scenario']} over {doc['duration']:g} s"))
        if why:
            blocks.append(Para(f"Not run: {why}."))
            continue
        blocks.append(Para(f"Reference: {doc['reference_note']}."))
        head = ["method", "step [s]", "error at T [rad]", "p", "energy (+ gained, − damped)",
                momentum_heading(doc["lines"]),
                "L's direction [rad]",
                *(f"within {b:g} rad" for b in THRESHOLDS)]
        rows = []
        for line in doc["lines"]:
            if line["status"] != "ok":
                mine = RUNNERS[line["method"]].engine == "xcheck"
                rows.append([Cell(line["method"], "fail" if mine else ""), Cell(f"{line['dt']:g}", num=True),
                             Cell(f"failed: {line['message']}"), "", "", "", "", "", ""])
                continue
            within = [line["within"][f"{b:g}"] for b in THRESHOLDS]
            verdict = "pass" if within[-1] >= doc["duration"] else ""
            rows.append([Cell(line["method"], verdict), Cell(f"{line['dt']:g}", num=True),
                         Cell(f"{line['final_error']:.3g}", num=True),
                         Cell("—" if line["growth"] is None else f"{line['growth']:.2f}", num=True),
                         *change_texts(line),
                         *(Cell(within_text(w, doc["duration"]), num=True) for w in within)])
        whole = sum(1 for line in doc["lines"] if line["status"] == "ok"
                    and line["within"][f"{THRESHOLDS[-1]:g}"] >= doc["duration"])
        for line in doc.get("left_out", []):
            blocks.append(Para(line, small=True))
        blocks.append(Table(head, rows, fold=f"{whole} of {len(rows)} runs (method and step) within "
                                             f"{THRESHOLDS[-1]:g} rad for the whole {doc['duration']:g} s; "
                                             f"{doc['wall_time']:.0f} s of CPU"))
        figures.append(figure)
        blocks.append(Figure(figure[0], figure[1]))
    summary = None
    if ok:
        summary = f"Horizons: {len(results)} scenarios over their long durations, every method of ours ran."
    return Section(blocks=blocks, figures=figures,
                   results={"horizons": {"passed": ok, "studies": [doc for doc, _, _ in results],
                                         "refused": [{"scenario": s, "why": w} for s, w in refused],
                                         "failed": [{"scenario": s, "method": m, "dt": dt} for s, m, dt in failed]}},
                   passed=ok, summary=summary)
