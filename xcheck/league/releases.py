"""Every MuJoCo release on the bundled scenarios and the boxes (issue 29): ``xcheck releases``.

Each release runs in the version matrix's cached environment (:mod:`xcheck.history.matrix`: ``pip install
mujoco==X``, everything else shared), where :func:`probe` runs MuJoCo's integrators alone on every bundled scenario
at its quick steps (orders, errors, the scenario's checks of them) and flies the boxes at 1e-3 s; the installed
release runs here. :func:`markdown` makes ``docs/mujoco-releases.md`` of the probes, with the date and xcheck's
version. :func:`bisect` finds the first release whose free-body RK4 is fourth order probing as few releases as a
binary search needs (``xcheck releases --bisect``).

The finding it made is recorded in :mod:`.findings` (``RK4_FOURTH_ORDER_FROM``): a study on an older MuJoCo still
fails its RK4's order check (that is the point), and ``release_note`` names the finding and the first good release
in the check's message.
"""

from __future__ import annotations

import json
import subprocess
from collections import Counter
import sys
import tempfile
from datetime import datetime, timezone
from pathlib import Path

from ..engines.findings import RELEASES, RK4_FOURTH_ORDER_FROM, release_key, release_note

__all__ = ["RELEASES", "RK4_FOURTH_ORDER_FROM", "release_key", "release_note", "probe", "run_probe", "bisect",
           "markdown"]

#: The scenario the bisection probes: a free, asymmetric body tumbling torque free (exact reference)
PROBE_SCENARIO = "tumbler-intermediate-axis"
#: What MuJoCo's changelog says of rotating bodies, by release (the issue's reading of it; the table's numbers show
#: what each did to these bodies)
CHANGELOG = {
    "3.7.0": "free bodies integrated at the midpoint in implicit and implicitfast",
    "3.11.0": "implicitfast: gyroscopic derivatives replace the midpoint; \"tumbling motion is now mildly damped\"",
}


# -----------------------------------------------------------------------------------------------------
# in a release's environment
# -----------------------------------------------------------------------------------------------------
def probe(quick: bool = True, scenarios=None, workers: int | None = 1) -> dict:
    """MuJoCo's integrators on every bundled scenario (or ``scenarios``) and on the boxes, in this environment."""
    import dataclasses

    import mujoco

    from ..scenario import bundled_scenarios, resolve_scenario
    from ..study import default_methods, run_studies
    from .boxes import CASES
    from .run import MUJOCO_INTEGRATORS, mujoco_rows

    chosen = []
    for name in scenarios or bundled_scenarios():
        sc = resolve_scenario(name)
        ours = [m for m in default_methods(sc) if m.startswith("mujoco-")]
        if ours:
            chosen.append(dataclasses.replace(sc, methods=ours))
    studies = run_studies(chosen, quick=quick, workers=workers)
    out = {"mujoco": mujoco.__version__, "scenarios": {}, "boxes": []}
    for st in studies:
        out["scenarios"][st.name] = {
            "passed": st.passed,
            "methods": {m: {"expected": e["expected_order"], "observed": e["observed_order"],
                            "finest": min((r["attitude_error"] for r in e["runs"] if r["attitude_error"] is not None),
                                          default=None),
                            "energy_change": _finest(e, "energy_change"), "verdict": e["verdict"]}
                        for m, e in st.data["methods"].items()},
            "failed": [c["name"] + ": " + (c.get("note") or "") for c in st.data["checks"] if not c["passed"]]}
    for case in CASES:
        for integrator in MUJOCO_INTEGRATORS:
            out["boxes"] += mujoco_rows(case, integrator, steps=(1e-3,))
    return out


def _finest(entry, key):
    runs = [r for r in entry["runs"] if r.get(key) is not None]
    return min(runs, key=lambda r: r["dt"])[key] if runs else None


def _main(argv) -> int:
    """``python -m xcheck.league.releases OUT.json [--full] [SCENARIO ...]``: :func:`probe` into OUT.json."""
    import warnings

    warnings.filterwarnings("ignore", category=UserWarning, module=r"xcheck\.models")  # the notes: said elsewhere
    out, *rest = argv
    full = "--full" in rest
    names = [a for a in rest if a != "--full"] or None
    data = probe(quick=not full, scenarios=names)
    Path(out).write_text(json.dumps(data, allow_nan=False))
    return 0


# -----------------------------------------------------------------------------------------------------
# from the running environment
# -----------------------------------------------------------------------------------------------------
class ReleaseError(RuntimeError):
    """A release that could not be probed; the message says why."""


def python_for(version: str, log=print) -> str:
    """The Python that runs MuJoCo ``version``: this one for the installed release, else its cached environment's
    (:func:`xcheck.history.matrix.ensure_env`, made once)."""
    from ..history.matrix import MatrixError, ensure_env, installed_mujoco

    if version == installed_mujoco():
        return sys.executable
    try:
        return str(ensure_env(version, log))
    except MatrixError as exc:
        raise ReleaseError(f"MuJoCo {version}: {exc}") from None


def run_probe(version: str, *, scenarios=None, quick: bool = True, log=print) -> dict:
    """:func:`probe` in MuJoCo ``version``'s environment (the installed release's here, in this process);
    :class:`ReleaseError` when it cannot run."""
    from ..history.matrix import installed_mujoco

    if version == installed_mujoco():
        import warnings

        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", category=UserWarning, module=r"xcheck\.models")  # said elsewhere
            return json.loads(json.dumps(probe(quick=quick, scenarios=scenarios), allow_nan=False))
    py = python_for(version, log)
    with tempfile.TemporaryDirectory(prefix="xcheck-release-") as tmp:
        out = Path(tmp) / "probe.json"
        cmd = [py, "-m", "xcheck.league.releases", str(out), *([] if quick else ["--full"]), *(scenarios or [])]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0 or not out.is_file():
            lines = [ln for ln in proc.stderr.strip().splitlines() if ln.strip()]
            raise ReleaseError(f"MuJoCo {version}: the probe failed (exit {proc.returncode}): "
                               f"{lines[-1] if lines else '(no message)'}")
        data = json.loads(out.read_text())
    if data["mujoco"] != version:
        raise ReleaseError(f"MuJoCo {version}: its environment imported MuJoCo {data['mujoco']}")
    return data


def rk4_order(data: dict) -> float | None:
    """The free-body RK4's observed order in a probe (on :data:`PROBE_SCENARIO`)."""
    return _observed(data, "mujoco-rk4")


def is_fourth_order(data: dict) -> bool:
    order = rk4_order(data)
    return order is not None and order >= 3.7


def bisect(versions, good, log=print) -> tuple[str | None, dict]:
    """The first of ``versions`` (sorted) for which ``good(version)`` holds, assuming that once good a release stays
    good, probing as a binary search does: ``(first good or None, {version: good})``. The newest is probed first
    (none good: None), then the oldest (already good: it)."""
    versions = sorted(versions, key=release_key)
    seen: dict = {}

    def ask(v):
        if v not in seen:
            seen[v] = bool(good(v))
            log(f"MuJoCo {v}: {'good' if seen[v] else 'not yet'}")
        return seen[v]

    if not versions or not ask(versions[-1]):
        return None, seen
    if ask(versions[0]):
        return versions[0], seen
    lo, hi = 0, len(versions) - 1  # versions[lo] not good, versions[hi] good
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if ask(versions[mid]):
            hi = mid
        else:
            lo = mid
    return versions[hi], seen


# -----------------------------------------------------------------------------------------------------
# the table
# -----------------------------------------------------------------------------------------------------
def _observed(data, method):
    return data["scenarios"].get(PROBE_SCENARIO, {}).get("methods", {}).get(method, {}).get("observed")


def _order(d) -> str:
    return "—" if d is None or d.get("observed") is None else f"{d['observed']:.2f}"


def _boxes(data, integrator, key="momentum_error"):
    row = next((r for r in data["boxes"] if r["case"] == "complex" and r["method"] == f"mujoco-{integrator}"), None)
    return "—" if row is None else f"{row[key]:.3g}"


def markdown(probes: dict, failures: dict, *, version: str, command: str, first_good: str | None) -> str:
    """``docs/mujoco-releases.md`` from ``probes`` ({release: probe}) and ``failures`` ({release: why})."""
    now = datetime.now(timezone.utc).strftime("%Y-%m-%d")
    releases = sorted({*probes, *failures}, key=release_key)
    lines = ["# Which MuJoCo release can I trust for rotating bodies?", "",
             f"Made by `{command}` on {now} with xcheck {version}; do not edit by hand. Every release runs MuJoCo's "
             "four integrators on every bundled scenario at its quick steps, against the exact or DOP853 reference "
             "(the same checks as the report), and flies the boxes benchmark's tumbling box at 1e-3 s "
             "(docs/league.md).", ""]
    if first_good:
        lines += [f"**Free-body RK4 is fourth order from MuJoCo {first_good} on**; before it, second order on every "
                  "bundled scenario with a rotating body, free and ball joints alike. A study on an older release "
                  "still fails its RK4's order check, and its message names this finding and the first good "
                  "release.", ""]
    second = [v for v in releases if v in probes and (_observed(probes[v], "mujoco-implicitfast") or 0) >= 1.7]
    if second:
        lines += [f"**implicitfast was second order** on the torque-free tumbler in MuJoCo {second[0]} … {second[-1]} "
                  "(free bodies integrated at the midpoint), and first order before and after: its boxes momentum error "
                  "at 1e-3 s fell from 1e-2 to 7e-6 and rose again. No release's first-order integrators come near "
                  "RK4 on rotating bodies.", ""]
    head = ["release", "scenarios passed", "RK4 order, tumbler (free)", "RK4 order, gyroscope", "RK4 order, heavy top "
            "(ball joint)", "implicitfast order, tumbler", "implicitfast energy change (+ gained), tumbler",
            "boxes ‖ΔH‖/‖H₀‖ at 1e-3 s: euler", "boxes: implicit", "boxes: implicitfast", "boxes: rk4",
            "changed from the release before (measured)",
            "changelog"]
    lines += ["## The releases", "", "| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 2) + "---|"]
    before = None
    for v in releases:
        if v in failures:
            lines.append(f"| {v} | not run: {failures[v]} |" + " |" * (len(head) - 2))
            continue
        d = probes[v]
        sc = d["scenarios"]
        passed = sum(s["passed"] for s in sc.values())
        tumbler = sc.get(PROBE_SCENARIO, {}).get("methods", {})
        drift = tumbler.get("mujoco-implicitfast", {}).get("energy_change")
        cells = [v, f"{passed} of {len(sc)}", _order(tumbler.get("mujoco-rk4")),
                 _order(sc.get("gyroscope-nonsingular", {}).get("methods", {}).get("mujoco-rk4")),
                 _order(sc.get("heavy-top", {}).get("methods", {}).get("mujoco-rk4")),
                 _order(tumbler.get("mujoco-implicitfast")), "—" if drift is None else f"{drift:+.2g}",
                 *(_boxes(d, i) for i in ("euler", "implicit", "implicitfast", "rk4"))]
        changed = "" if before is None else "; ".join(f"{head[k]} {before[k]} → {cells[k]}" for k in range(2, len(cells))
                                                       if cells[k] != before[k])
        before = cells
        lines.append("| " + " | ".join([*cells, changed, CHANGELOG.get(v, "")]) + " |")
    lines += ["", "## What failed, by release", "",
              "Each failed check of MuJoCo's integrators, with the number of bundled scenarios where it failed.", ""]
    for v in releases:
        if v in probes:
            counts = Counter(":".join(f.split(":", 2)[:2]) for s in probes[v]["scenarios"].values()
                             for f in s["failed"])
            lines.append(f"- **{v}**: " + ("nothing" if not counts else
                                           ", ".join(f"{name} in {n}" for name, n in sorted(counts.items()))))
    lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
