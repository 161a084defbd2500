"""Known findings the checks quote: what ``xcheck releases`` found (issue 29): an older MuJoCo's (or MJX's) failed
RK4 order check names the finding and the first good release (:mod:`xcheck.study.checks`); and the engines' findings
that explain a failed check where they are at work (issue 40). No imports: the study
reads it without loading the release machinery."""

from __future__ import annotations

#: The newest patch of every minor release from 3.2 to 4.0 (PyPI, 2026-12-02)
RELEASES = ("3.2.7", "3.3.7", "3.4.0", "3.5.0", "3.6.0", "3.7.0", "3.8.1", "3.9.0", "3.10.0", "3.11.0", "3.12.0",
            "3.13.0", "3.14.0", "3.15.0", "3.16.0", "3.17.0", "4.0.0")
#: The first release whose RK4 is fourth order on a free body (``xcheck releases``, docs/mujoco-releases.md):
#: before it, order 2 on every bundled scenario, free and ball joints alike
RK4_FOURTH_ORDER_FROM = "4.0.0"


def release_key(version: str) -> tuple:
    return tuple(int(x) for x in version.split("."))


def release_note(version: str | None, engine: str = "MuJoCo") -> str | None:
    """For a failed RK4 order check on MuJoCo ``version`` (or MJX's, which follows MuJoCo's numbering): the finding
    and the first good release; None from it on."""
    if not version or version == "not installed" or release_key(version) >= release_key(RK4_FOURTH_ORDER_FROM):
        return None
    if engine == "MJX":
        return (f"a known finding: MJX {version}'s RK4 is second order on rotating bodies, as MuJoCo's before "
                f"{RK4_FOURTH_ORDER_FROM} (docs/mjx.md)")
    return (f"a known finding: MuJoCo {version}'s RK4 is second order on rotating bodies (free and ball joints, "
            f"every bundled scenario); fourth order from MuJoCo {RK4_FOURTH_ORDER_FROM} on (docs/mujoco-releases.md)")


# ------------------------------------------------------------------------------------------------------------------
# Known findings of the engines that explain a failed check where they are at work (``Runner.known``, issue 40):
# ``(check, MethodResult, scenario) -> note or None``, from what the study measured; each has its test and its entry
# in docs/findings.md.
# ------------------------------------------------------------------------------------------------------------------
#: DART's exponential map is exact from this turn a step on [rad] (below it, ``expMapRot`` truncates its series)
DART_EXACT_TURN = 1e-3


def _rate(scenario) -> float:
    return sum(float(w) ** 2 for w in scenario.omega0) ** 0.5


def dart_truncated_exponential(check, method, scenario) -> str | None:
    """DART's ``expMapRot`` (math/Geometry.cpp) takes ``I + [phi] + [phi]^2/2`` below ``|phi| = 1e-3`` rad: a step
    turning the body by less errs by ``(h w)^3/6``, a floor under the error that no smaller step removes."""
    f = method.finest
    if check.kind not in ("order", "final-error") or f is None:
        return None
    turn = f.dt * _rate(scenario)
    if not 0 < turn < DART_EXACT_TURN:
        return None
    return (f"a known finding: DART's exponential map is truncated below {DART_EXACT_TURN:g} rad a step (expMapRot, "
            f"math/Geometry.cpp: I + [φ] + [φ]²/2), an error of (hω)³/6 a step; the finest step here turns the body "
            f"{turn:.2g} rad (docs/findings.md)")


def _on_ball_joint(scenario) -> bool:
    """Whether the scenario's body is a top (its MJCF declares a ball joint): no quaternion in Drake's state then."""
    from .mechanism import joint_kinds

    return "ball" in joint_kinds(scenario.model)


def drake_additive_quaternion(check, method, scenario) -> str | None:
    """Drake's Euler methods integrate the free body's quaternion additively, ``q + h q'`` (its norm let drift):
    the turn a step is ``2 atan(h w / 2)`` instead of ``h w``, an error of second order that outweighs the rates'
    first-order one where the rates are nearly steady (a fast spin): an observed order near 2. A free body's only:
    a top turns on Drake's roll-pitch-yaw ball joint, a gyrostat's bus is free."""
    if check.kind != "order" or method.expected_order is None or _on_ball_joint(scenario):
        return None
    observed = check.value if check.value is not None else _last_local_order(method)
    if observed is None or observed <= method.expected_order + 0.5:
        return None
    return (f"a known finding: Drake integrates the free body's quaternion additively (q + h q̇, unnormalised), an "
            f"error of second order that outweighs the rates' first-order one at these steps (observed order "
            f"{observed:.2f}{'' if check.value is not None else ', between the two finest steps'}; docs/findings.md)")


def _completed(method) -> list:
    """A method's completed runs with an error, coarse to fine."""
    return [r for r in sorted(method.runs, key=lambda r: -r.dt) if r.ok and r.attitude_error is not None]


def _last_local_order(method) -> float | None:
    """The order between a method's two finest completed runs (where the fit has too few steps in its range)."""
    import math

    runs = [r for r in _completed(method) if r.attitude_error > 0]
    if len(runs) < 2:
        return None
    (h1, e1), (h2, e2) = ((r.dt, r.attitude_error) for r in runs[-2:])
    return math.log(e1 / e2) / math.log(h1 / h2)


#: At the finest step, a quaternion's norm off unit or an energy off its start by more than these shows the steps still
#: coarse for Drake's explicit Euler on this motion
DRAKE_NORM_PRE_ASYMPTOTIC = 0.01
DRAKE_ENERGY_PRE_ASYMPTOTIC = 0.005


def drake_explicit_euler_pre_asymptotic(check, method, scenario) -> str | None:
    """Drake's explicit Euler reaches its first order only at fine steps on a fast or tumbling motion (the bundled
    gyroscope: local orders 0.58, 0.75, 0.87 from 1/2048 to 1/8192 s, 0.96 at 1/32768 s). At work where its error still
    falls at the finest steps (it converges: not a defect) and the finest run shows the steps coarse for the motion:
    its unnormalised quaternion's norm, which grows by ``(1 + (h w / 2)^2)^(1/2)`` a step, or its energy, which
    explicit Euler raises, off by more than :data:`DRAKE_NORM_PRE_ASYMPTOTIC` / :data:`DRAKE_ENERGY_PRE_ASYMPTOTIC`."""
    runs = _completed(method)
    if check.kind != "order" or len(runs) < 2 or runs[-1].attitude_error >= runs[-2].attitude_error:
        return None
    if check.value is not None and method.expected_order is not None and check.value > method.expected_order:
        return None
    f = runs[-1]
    norm, energy = f.norm_drift or 0.0, f.energy_change or 0.0
    if norm <= DRAKE_NORM_PRE_ASYMPTOTIC and abs(energy) <= DRAKE_ENERGY_PRE_ASYMPTOTIC:
        return None
    shown = ([] if _on_ball_joint(scenario) else [f"its quaternion's norm is {norm:.2g} off unit"]) + \
        [f"its energy {energy:+.2g} off ({'gained' if energy > 0 else 'lost'})"]
    return (f"a known finding: Drake's explicit Euler reaches its first order only at fine steps on a fast or tumbling "
            f"motion (the bundled gyroscope: 0.58 to 0.87 from 1/2048 to 1/8192 s); its error still falls, and at the "
            f"finest step {' and '.join(shown)} (docs/findings.md)")
