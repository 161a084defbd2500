"""Convergence studies: every method x every step of a scenario against its reference, in worker
processes (deterministic: each run is independent), producing results of schema ``xcheck.convergence/3``
plus the sampled series the report plots.

The package: this module plans the studies and assembles their results (:class:`StudyResult`);
:mod:`~xcheck.study.executor` runs the tasks, :mod:`~xcheck.study.context` holds what a worker keeps per
scenario, :mod:`~xcheck.study.measure` measures a method in a worker, :mod:`~xcheck.study.checks` makes the
checks and verdicts."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..base.errors import UsageError
from ..metrics import (
    TOLERANCES,
    StepWithin,
    ladder_steps,
    largest_step_within,
    observed_order,
    tolerance_key,
)
from ..motion import FLIPS_HOW, PRECESSION_HOW
from ..results import Check, MethodResult
from ..engines.mechanism import joint_kinds
from ..runners import RUNNERS
from ..scenario import Scenario, check_steps
from ..trajectory import step_label
from ..versions import versions
from .advice import advice
from .checks import adaptive_note, planned_checks, qualify, study_checks, study_floor, verdict
from .executor import map_tasks, prefer_here
from .files import read_trajectories, score_trajectories
from .finer import finer_steps, merged
from .measure import PLOT_SAMPLE_DT, resolve_comparisons, run_methods
from .statements import accuracy, consistency
from .store import keep, stored, study_key
from .your_step import your_step_answer

__all__ = ["run_study", "run_studies", "starting", "COMPILING", "assemble", "StudyResult", "PLOT_SAMPLE_DT",
           "throughput_rows", "planned_checks", "default_methods", "not_run", "comparison_partner", "method_steps",
           "left_out_lines", "finer_lines", "FINER"]

#: 2: the answer at the user's step, ``your_step`` (issue 59); 3: the invariants signed and apart (issue 60)
SCHEMA = "xcheck.convergence/3"


@dataclass
class StudyResult:
    """A study's findings, typed (:mod:`xcheck.results`): the scenario, its steps (coarse to fine), every
    method's result, the checks; ``series``: per method, the sampled finest good run (``t``, ``q``, ``omega``,
    ``attitude_error``, ``energy``, ``momentum``, ``euler``) and the reference on the same times, for plots and
    CSV. :attr:`data` is the JSON (schema ``xcheck.convergence/3``)."""

    scenario: Scenario
    steps: list
    methods: dict  # name -> MethodResult
    checks: list  # of Check
    order_floor: float
    quick: bool = False
    series: dict = field(default_factory=dict)
    comparisons: list = field(default_factory=list)  # {"a", "b", "dt", "max_attitude_difference"}
    versions: dict = field(default_factory=versions)
    #: what the guard of an exact reference found (:meth:`xcheck.guard.ReferenceCheck.to_json`, with its sentence
    #: ``text``): the closed form used, or DOP853 instead and why; None for a numerical reference
    reference_check: dict | None = None
    #: why the study cannot decide, beyond its checks' own notes (a suspect or uncertain reference, a vacuous study)
    inconclusive: list = field(default_factory=list)
    #: the torque the model exerts itself, in words (a top's gravity, a gyrostat's wheels); None: none
    model_torque: str | None = None
    #: a gyrostat's wheels stiffening its attitude (:func:`xcheck.assembly.wheels_stiffness`), full studies only
    wheels_stiffness: dict | None = None
    #: the scenario's trajectory files, scored (name -> :class:`xcheck.scoring.score.FileScore`)
    files: dict = field(default_factory=dict)
    #: methods left out because they cannot represent the scenario's body: name -> why
    not_run: dict = field(default_factory=dict)
    #: an engine's finest steps left out by its step budget (:func:`method_steps`): name -> (steps, why)
    over_budget: dict = field(default_factory=dict)
    #: the answer at the user's own step (:func:`~xcheck.study.your_step.your_step_answer`); None: no step of theirs
    your_step: dict | None = None
    #: a tumbling body's flips (:mod:`xcheck.motion`): how they are measured and the reference's; each method's are in
    #: its ``accurate`` (at the step its row is judged at) and in ``your_step``; None where the body does not tumble
    flips: dict | None = None
    #: a top's or an axisymmetric body's cone (:mod:`xcheck.motion`): how it is measured and the reference's; each
    #: method's in its ``accurate`` and ``your_step`` entries; None for any other body
    precession: dict | None = None
    #: what to use instead, per engine (:func:`~xcheck.study.advice.advice`): its cheapest method and largest studied
    #: step within the tolerance over the run
    advice: list = field(default_factory=list)
    #: what each engine of the study was given for the body (:mod:`xcheck.engines.built`): ``{"body": the body in
    #: words, "engines": engine -> sentence}``; {} where no method said
    built: dict = field(default_factory=dict)
    #: the finer steps run beyond the study's to decide an engine's order (:mod:`xcheck.study.finer`): name -> steps
    finer: dict = field(default_factory=dict)

    @property
    def outcome(self) -> str:
        """``FAILED`` (a check failed), ``INCONCLUSIVE`` (a check could not decide, or the study tests nothing) or
        ``PASSED`` (:data:`xcheck.results.OUTCOMES`)."""
        if any(c.failed for c in self.checks):
            return "FAILED"
        return "INCONCLUSIVE" if self.inconclusive or any(c.inconclusive for c in self.checks) else "PASSED"

    @property
    def reference_used(self) -> str:
        """The reference the study measured against: the scenario's, or DOP853 where the guard refused the exact one."""
        return self.reference_check["used"] if self.reference_check else self.scenario.reference

    @property
    def name(self) -> str:
        return self.scenario.name

    @property
    def passed(self) -> bool:
        return self.outcome == "PASSED"

    @property
    def data(self) -> dict:
        sc = self.scenario
        return {"schema": SCHEMA, "scenario": sc.name, **({"your_step": self.your_step} if self.your_step else {}),
                "description": sc.description, "model": str(sc.model),
                "duration": sc.duration, "reference": sc.reference, "torque": sc.torque,
                "initial": {"quaternion": sc.q0.tolist(), "angular_velocity": sc.omega0.tolist(),
                            "euler_sequence": sc.sequence},
                "quick": self.quick, "steps": list(self.steps), "order_floor": self.order_floor,
                "versions": self.versions, "methods": {n: m.to_json() for n, m in self.methods.items()},
                "checks": [c.to_json() for c in self.checks], "passed": self.passed, "outcome": self.outcome,
                **({"inconclusive": list(self.inconclusive)} if self.inconclusive else {}),
                "comparisons": list(self.comparisons),
                **({"reference_check": dict(self.reference_check)} if self.reference_check else {}),
                **({"assumptions": list(sc.assumptions)} if sc.assumptions else {}),
                **({"wheel_speeds": list(sc.wheel_speeds)} if sc.wheel_speeds is not None else {}),
                **({"model_torque": self.model_torque} if self.model_torque else {}),
                **({"wheels_stiffness": self.wheels_stiffness} if self.wheels_stiffness else {}),
                **({"files": {n: f.to_json() for n, f in self.files.items()}} if self.files else {}),
                **({"not_run": dict(self.not_run)} if self.not_run else {}),
                **({"over_budget": {m: {"steps": list(d), "why": why} for m, (d, why) in self.over_budget.items()}}
                   if self.over_budget else {}),
                **({"flips": dict(self.flips)} if self.flips else {}),
                **({"precession": dict(self.precession)} if self.precession else {}),
                **({"advice": list(self.advice)} if self.advice else {}),
                **({"finer": {m: list(d) for m, d in self.finer.items()}} if self.finer else {}),
                **({"built": dict(self.built)} if self.built else {})}


def default_methods(scenario: Scenario) -> list[str]:
    """The scenario's methods, else every runner but an opt-in engine's that ``$XCHECK_WITH`` does not name, and one
    that cannot represent the scenario's body (:func:`not_run`)."""
    if scenario.methods:
        return list(scenario.methods)
    left_out = not_run(scenario)
    return model_integrator_first(scenario, [m for m, r in RUNNERS.items() if _offered(r) and m not in left_out])


def model_integrator_first(scenario: Scenario, methods: list) -> list:
    """``methods`` with MuJoCo's the model runs with (``<option integrator>``: :attr:`Scenario.your_integrator`) first
    among MuJoCo's, the others in their order (issue 59)."""
    own = f"mujoco-{scenario.your_integrator}"
    if own not in methods:
        return methods
    slots = [i for i, m in enumerate(methods) if RUNNERS[m].engine == "mujoco"]
    ordered = sorted((methods[i] for i in slots), key=lambda m: m != own)
    out = list(methods)
    for i, m in zip(slots, ordered):
        out[i] = m
    return out


def _offered(runner) -> bool:
    """Whether a study offers ``runner`` at all: not an opt-in engine's, unless ``$XCHECK_WITH`` names it."""
    from ..engines import asked_for

    return not runner.opt_in or asked_for(runner.engine)


def not_run(scenario: Scenario) -> dict:
    """The methods a study of ``scenario`` leaves out because they cannot represent its body, and why (the report
    says so: never a silent gap); none when the scenario names its methods (run_study refuses one that cannot run)."""
    if scenario.methods:
        return {}
    return {m: why for m, r in RUNNERS.items() for why in [r.cannot_run(scenario.model)] if why}


def method_steps(scenario: Scenario, method: str, steps, *, quick: bool = False) -> tuple[tuple, tuple, str]:
    """``(steps run, steps left out, why)`` of ``method`` in a study at ``steps`` (coarse to fine): every step, but for
    an engine with a step budget (:attr:`xcheck.engines.Engine.step_budget`, ``quick_step_budget`` in a ``quick``
    study; under a torque or on joints only, for an engine whose free torque-free runs are compiled end to end) only
    the coarsest whose
    steps add up to it at most, three at least (an order needs them)."""
    from ..engines import ENGINES
    from ..trajectory import step_plan

    steps = tuple(steps)
    engine = ENGINES.get(RUNNERS[method].engine)
    compiled = engine is not None and engine.budget_under_torque and not scenario.torque \
        and not joint_kinds(scenario.model)  # a free body's torque-free run, compiled end to end
    budget = None if engine is None or RUNNERS[method].adaptive or compiled \
        else engine.quick_step_budget if quick else engine.step_budget
    if budget is None:
        return steps, (), ""
    kept, total = [], 0
    for dt in steps:
        total += step_plan(float(dt), scenario.duration)[0]
        if total > budget and len(kept) >= 3:
            break
        kept.append(dt)
    left = steps[len(kept):]
    why = (f"the step budget of {budget:,} steps a method and study of an engine that takes microseconds a step "
           f"where ours take a tenth of one") if left else ""
    return tuple(kept), left, why


def engine_said_lines(st: StudyResult) -> list[str]:
    """What each method's engine wrote to the standard error in its runs (caught there: :mod:`xcheck.base.captured`),
    a line per method and note, with the runs it came in: what the report and the terminal say of it."""
    from ..trajectory import step_label
    from .measure import SAID

    out = []
    for name, m in st.methods.items():
        notes: dict = {}
        for r in m.runs:
            for part in (r.message or "").split("; "):
                if SAID in part:
                    notes.setdefault(part, []).append(r)
        for note, runs in notes.items():
            where = ("in every run" if len(runs) == len(m.runs) else
                     f"in {len(runs)} of its {len(m.runs)} runs (at {', '.join(step_label(r.dt) for r in runs)} s)")
            out.append(f"{name}, {where}: {note}")
    return out


def left_out_lines(st: StudyResult) -> list[str]:
    """What a study left out, one line for the methods left out for the same reason (at the same steps): those that
    cannot represent its body (:attr:`StudyResult.not_run`), an engine's steps beyond its budget
    (:func:`method_steps`). What the report and the terminal say: never a silent gap."""
    from ..trajectory import step_label

    groups: dict = {}
    for name, why in st.not_run.items():
        groups.setdefault(("", why), []).append(name)
    for name, (left, why) in st.over_budget.items():
        groups.setdefault((f" at {', '.join(step_label(d) for d in left)} s", why), []).append(name)
    return [f"{', '.join(names)} not run{where}: {why}" for (where, why), names in groups.items()]


def finer_lines(st: StudyResult) -> list[str]:
    """The finer steps a study ran beyond its own to decide an engine's order (:attr:`StudyResult.finer`), one line
    for the methods run at the same steps: what the report and the terminal say of them."""
    from ..trajectory import step_label

    groups: dict = {}
    for name, dts in st.finer.items():
        groups.setdefault(tuple(dts), []).append(name)
    out = []
    for dts, names in groups.items():
        orders = [st.methods[n].observed_order if n in st.methods else None for n in names]
        said = ", ".join("—" if p is None else f"{p:.2f}" for p in orders)
        out.append(f"{', '.join(names)} also run at {', '.join(step_label(d) for d in dts)} s, finer than the study's "
                   f"steps, to decide {'its' if len(names) == 1 else 'their'} order (the finest errors were still too "
                   f"large to show one): observed {said}")
    return out


def comparison_partner(scenario: Scenario, method: str, methods) -> str | None:
    """Which of our methods an engine's method is compared with directly, trajectory against trajectory at
    the same step (no reference needed): its twin (the same scheme: MuJoCo's RK4 and ``lie-rkmk4``, Basilisk's
    and ``mrp-rk4``) when the study has it, else one of the same order, the scenario's ``reference_method`` first,
    then ``lie-rkmk4``; for an engine method of an order none of ours has (MuJoCo's first-order ones), our
    highest-order method, so that the difference measures the engine's own error. None for our methods, or
    when the study has none of ours to compare with."""
    runner = RUNNERS[method]
    if runner.engine == "xcheck" or runner.adaptive:  # an adaptive method's runs share one output step
        return None
    ours = [m for m in methods if RUNNERS[m].engine == "xcheck" and RUNNERS[m].expected_order is not None
            and m not in scenario.checks.get("expected_to_fail", ())]
    if not ours:
        return None
    if runner.twin in ours:  # the same scheme as the engine's: their difference is the engine's own
        return runner.twin
    preferred = sorted(ours, key=lambda m: (m != scenario.reference_method, m != "lie-rkmk4"))
    same = [m for m in preferred if RUNNERS[m].expected_order == runner.expected_order]
    return same[0] if same else max(preferred, key=lambda m: RUNNERS[m].expected_order)


def run_study(scenario: Scenario, *, methods=None, steps=None, quick: bool = False, workers: int | None = None,
              progress=None, pool=None, timing: bool = True, here: bool = False) -> StudyResult:
    """Run the convergence study of ``scenario``.

    ``methods``/``steps`` override the scenario's; ``quick`` uses its ``quick_steps`` (and an adaptive method
    its ``quick_tolerances``). ``workers`` processes (default: the CPU count; 1 runs in this process).
    ``progress(done, total, label)`` is called as runs finish. ``pool`` reuses an existing executor (the report
    runs all scenarios in one).
    """
    methods = list(methods) if methods else default_methods(scenario)
    steps_given = steps is not None
    for m in methods:
        if m not in RUNNERS:
            raise ValueError(f"methods: unknown {m!r}; expected one of {', '.join(RUNNERS)}")
        why = RUNNERS[m].cannot_run(scenario.model)
        if why:
            raise UsageError(f"methods: {m} cannot run {scenario.name}: {why}")
    steps = sorted((float(s) for s in (steps or (scenario.quick_steps if quick else scenario.steps))), reverse=True)
    try:
        check_steps(steps, scenario.duration)
    except ValueError as exc:
        raise ValueError(f"steps: {exc}") from None
    tolerances = scenario.quick_tolerances if quick else scenario.tolerances
    # the engines' step budgets hold for the scenario's steps, not for steps asked for by name
    planned = {m: (tuple(steps), (), "") if steps_given else method_steps(scenario, m, steps, quick=quick)
               for m in methods}
    as_quick = quick and not steps_given  # the quick study's checks: only at its own steps
    key = study_key(scenario, methods, steps, tolerances, as_quick)
    kept = stored(key, timing)
    if kept is not None:
        return kept
    read_trajectories([scenario])  # a bad file refused before the work
    tasks = study_tasks(scenario, methods, planned, tolerances, timing)
    starting(progress, len(tasks))
    guard_references([scenario])
    done = map_tasks(run_methods, tasks, workers=workers, progress=progress, pool=pool,
                     labels=[_label(task) for task in tasks], here=prefer_here if here else None)
    by_method = {r.method: r for task_runs in done for r in task_runs}
    results = [by_method[m] for m in methods]
    st = assemble(scenario, steps, results, quick=as_quick, planned=planned)
    finer = _finer(st, as_quick)
    if finer:  # an engine's order undecided at the study's steps: its next halvings, where they are cheap
        [runs] = _finer_round([(scenario, finer, tolerances)], timing, workers=workers, progress=progress, pool=pool,
                              here=here)
        st = assemble(scenario, steps, merged(results, runs), quick=as_quick, planned=planned, finer=finer)
    st = score_trajectories(about_the_model(st, quick))
    keep(key, st, timing)
    return st


#: What the bar says while a study runs the finer steps that decide an engine's order (:mod:`xcheck.study.finer`).
FINER = "finer steps to decide an engine's order"


def _finer(st: StudyResult, quick: bool) -> dict:
    """The finer steps (:func:`~xcheck.study.finer.finer_steps`) a study ``st`` runs to decide its engines' orders."""
    return finer_steps(st.scenario, st.methods, st.checks, st.over_budget, quick, WIDE_CEILING)


def _finer_round(wanted, timing: bool, *, workers, progress, pool, here) -> list[list]:
    """The runs at their finer steps of every ``(scenario, method -> finer steps, tolerances)`` of ``wanted``, in one
    round of tasks (:func:`map_tasks`): per entry, its methods' :class:`~xcheck.results.MethodRuns`."""
    owned = [(k, task) for k, (sc, finer, tol) in enumerate(wanted)
             for task in study_tasks(sc, list(finer), {m: (d, (), "") for m, d in finer.items()}, tol, timing)]
    starting(progress, len(owned), FINER)
    done = map_tasks(run_methods, [task for _, task in owned], workers=workers, progress=progress, pool=pool,
                     labels=[_label(task) for _, task in owned], here=prefer_here if here else None)
    out: list = [[] for _ in wanted]
    for (k, _), task_runs in zip(owned, done):
        out[k] += task_runs
    return out


def study_tasks(scenario: Scenario, methods, planned: dict, tolerances, timing: bool = True) -> list[tuple]:
    """The tasks of a study (:func:`~xcheck.study.measure.run_methods`'s arguments): one a method, but one for all the
    methods of an engine that runs them as one (:attr:`xcheck.engines.Engine.one_task`: its import paid once, in one
    process)."""
    from ..engines import ENGINES

    groups: dict = {}
    for m in methods:
        engine = ENGINES.get(RUNNERS[m].engine)
        groups.setdefault(engine.name if engine is not None and engine.one_task else m, []).append(m)
    return [(scenario, tuple(ms), tuple(planned[m][0] for m in ms),
             tuple(comparison_partner(scenario, m, methods) for m in ms), tolerances, timing)
            for ms in groups.values()]


def _label(task) -> str:
    return f"{task[0].name}: {', '.join(task[1])}"


def about_the_model(st: StudyResult, quick: bool = False) -> StudyResult:
    """What the report says of the model beside the study's numbers, taken once from the study's own body and torque
    (the report neither reloads the MJCF nor integrates): the model's own torque in words and, for a full study of a
    gyrostat, how its wheels stiffen the attitude. ``st``, filled in."""
    from ..assembly import wheels_stiffness
    from .context import run_context

    try:
        ctx = run_context(st.scenario)
    except ValueError:  # the study said why
        return st
    st.model_torque = None if ctx.own is None else ctx.own.describe()
    if not quick:
        st.wheels_stiffness = wheels_stiffness(st.scenario)
    return st


def run_studies(scenarios, *, quick: bool = False, workers: int | None = None, progress=None,
                pool=None, on_study=None, here: bool = False, idle=None) -> list[StudyResult]:
    """Several studies over one pool of worker processes: every (scenario, method) pair is one task,
    submitted together so that both cores stay busy to the end. ``on_study(study)`` is called as soon as a
    scenario's last task is in (the report submits its figures then, behind the studies still queued). ``here``:
    this process runs tasks too, beside ``pool``, and ``idle()``'s work where it would wait for the workers
    (:func:`~xcheck.study.executor.map_tasks`)."""
    plans = []
    for sc in scenarios:
        methods = default_methods(sc)
        steps = sorted((float(s) for s in (sc.quick_steps if quick else sc.steps)), reverse=True)
        plans.append((sc, methods, steps, {m: method_steps(sc, m, steps, quick=quick) for m in methods}))
    tolerances = [sc.quick_tolerances if quick else sc.tolerances for sc in scenarios]
    per_study = [study_tasks(sc, methods, planned, tol) for (sc, methods, _, planned), tol in zip(plans, tolerances)]
    keys = [study_key(sc, methods, steps, tol, quick) for (sc, methods, steps, _), tol in zip(plans, tolerances)]
    read_trajectories(scenarios)  # a bad file refused before the work
    tasks = [task for ts in per_study for task in ts]
    starting(progress, len(tasks))
    guard_references(scenarios)
    owner = [k for k, ts in enumerate(per_study) for _ in ts]
    missing = [len(ts) for ts in per_study]
    studies: list = [None] * len(plans)
    results: list = [{} for _ in plans]  # per study: method -> MethodRuns

    finer: dict = {}  # study -> method -> finer steps (issue 63): those studies end after a second round

    def finish(k, st):
        studies[k] = score_trajectories(about_the_model(st, quick))
        keep(keys[k], studies[k], True)
        if on_study:
            on_study(studies[k])

    def done(i, task_runs):
        k = owner[i]
        results[k].update((r.method, r) for r in task_runs)
        missing[k] -= 1
        if missing[k] == 0:
            sc, methods, steps, planned = plans[k]
            st = assemble(sc, steps, [results[k][m] for m in methods], quick=quick, planned=planned)
            finer[k] = _finer(st, quick)
            if not finer[k]:
                finish(k, st)

    map_tasks(run_methods, tasks, workers=workers, progress=progress, pool=pool, labels=[_label(t) for t in tasks],
              on_result=done, here=prefer_here if here else None, idle=idle)
    later = [k for k, f in finer.items() if f]
    if later:
        rounds = _finer_round([(plans[k][0], finer[k], tolerances[k]) for k in later], True, workers=workers,
                              progress=progress, pool=pool, here=here)
        for k, runs in zip(later, rounds):
            sc, methods, steps, planned = plans[k]
            finish(k, assemble(sc, steps, merged([results[k][m] for m in methods], runs), quick=quick,
                               planned=planned, finer=finer[k]))
    return studies


#: What the bar says while a first run compiles (issue 61: a cold start shows progress from its first second).
COMPILING = "compiling xcheck's integrators for this machine (once per release)"


def starting(progress, total: int, what: str | None = None) -> None:
    """The bar's first line, before the first run ends (the reference's check, and on a first run the compiling, take
    seconds of their own): what is being done meanwhile (``what``, where it is known)."""
    if progress:
        from ..integrators import compile_cache_is_cold

        progress(0, total, what or (COMPILING if compile_cache_is_cold() else "checking the reference"))


def guard_references(scenarios) -> None:
    """Check each exact reference once, here, before its tasks go to the workers (issue 36: the guard,
    :func:`xcheck.guard.check_exact`), and give the scenario what it found (``Scenario.guarded``): a worker then
    builds the reference the guard chose without checking it again (and one that drives only Basilisk never loads
    compiled code for it). A reference that cannot be built is left to the workers, which report it."""
    from ..reference import ReferenceFailure
    from .context import scenario_key, scenario_reference

    for sc in scenarios:
        if sc.reference == "exact":
            try:
                sc.guarded = (scenario_key(sc), scenario_reference(sc).check)
            except ReferenceFailure:
                pass


def _fitted(runs) -> list:
    """The runs' attitude errors an order is fitted on: None for a run whose steps were taken as substeps (the LGVI
    where its equation has no solution at the step): that run is not the method at its step."""
    return [None if r.substeps else r.attitude_error for r in runs]


#: Where no order is measured below :data:`~xcheck.metrics.ORDER_CEILING`, errors up to this [rad] may measure one
#: (issue 63): an attitude error is the angle of the error rotation, linear in the error's generator far from pi
#: (at 1 rad, within 4 % of it), so a first-order engine 0.33, 0.16, 0.082 rad off at 1/512 … 1/2048 s on a
#: near-separatrix body shows its order 1.00, 1.00 there, where the small-error regime would need 1/65536 s.
WIDE_CEILING = 1.0
#: ... when its local orders there agree to this: a method still settling into its asymptotic range does not.
WIDE_AGREEMENT = 0.1


def _wide_orders(scenario: Scenario, methods: dict, checks: list, floor: float) -> bool:
    """Give each engine method whose order check is undecided for want of an order in the small-error regime (its
    steps pre-asymptotic there) the order fitted on errors up to :data:`WIDE_CEILING`, where three runs or more fall
    below it and their finest local orders (:data:`~xcheck.metrics.ORDER_POINTS`) agree to :data:`WIDE_AGREEMENT`
    (``methods``, in place). Only those: an order decided, or a known finding named, stays as it was. Whether any
    did (the checks are then made again)."""
    from ..metrics import ORDER_CEILING, ORDER_POINTS

    changed = False
    for c in checks:
        m = methods.get(c.method)
        if not (c.kind == "order" and c.inconclusive and c.value is None and m is not None and not m.adaptive):
            continue
        ladder = set(ladder_steps([r.setting for r in m.runs], scenario.your_step))  # the steps assemble fits
        runs = [r for r in m.runs if r.setting in ladder]
        fit = observed_order([r.setting for r in runs], _fitted(runs), floor=floor, ceiling=WIDE_CEILING)
        finest = fit.local_orders[-ORDER_POINTS:]
        if fit.order is None or len(finest) < 2 or max(finest) - min(finest) > WIDE_AGREEMENT:
            continue
        local = ", ".join(f"{p:.2f}" for p in finest)
        methods[c.method] = replace(m, observed_order=fit.order, local_orders=fit.local_orders, order_note=(
            f"{fit.note}, on errors up to {WIDE_CEILING:g} rad (fewer than two fell within the {ORDER_CEILING:g} rad "
            f"of the small-error regime: its local orders here, {local}, agree to {WIDE_AGREEMENT:g})"))
        changed = True
    return changed


def _substepped(dts) -> str:
    """The order note's words for the runs left out of it because their steps were taken as substeps."""
    at = ", ".join(step_label(dt) for dt in dts)
    runs = "the run" if len(dts) == 1 else "the runs"
    return (f"{runs} at {at} s took substeps (its implicit equation has no solution at a step that large): left "
            "out of its order")


def assemble(scenario: Scenario, steps, results, *, quick: bool = False, planned=None, finer=None) -> StudyResult:
    """Orders, checks and verdicts from the workers' results. ``quick``: the final-error and invariant
    checks, which are about the finest steps of the full study, are not applied. ``planned``: each method's
    :func:`method_steps` (what it left out is said). ``finer``: the finer steps run to decide an engine's order
    (:mod:`xcheck.study.finer`), already among its runs (said)."""
    broken = {}
    for res in results:  # an engine installed but failing to import here: left out, said, and in the versions line
        if res.import_error:
            from ..versions import note_import_failure

            broken[res.method] = f"{RUNNERS[res.method].engine} is installed but fails to import here: {res.import_error}"
            note_import_failure(RUNNERS[res.method].engine, res.import_error)
    results = [res for res in results if not res.import_error]
    floor = study_floor(results)
    methods, series = {}, {}
    for res in results:
        name = res.method
        runner = RUNNERS[name]
        runs = res.runs
        x = [r.setting for r in runs]
        ladder = set(x if runner.adaptive else ladder_steps(x, scenario.your_step))
        on_ladder = [r for r in runs if r.setting in ladder]
        fit = observed_order([r.setting for r in on_ladder], _fitted(on_ladder), floor=floor)
        if fit.order is None and len(on_ladder) < len(runs):  # none on the ladder alone: the user's steps too
            fit = observed_order(x, _fitted(runs), floor=floor)
        split = [r.dt for r in runs if r.substeps]
        if split:
            fit = replace(fit, note=f"{fit.note}; {_substepped(split)}" if fit.note else _substepped(split))
        within = {tolerance_key(tol): largest_step_within(
            x, [r.max_attitude_error if r.ok else None for r in runs], [r.wall_time for r in runs], tol)
            for tol in TOLERANCES}
        order, note, local = fit.order, fit.note, fit.local_orders
        if runner.adaptive:  # its ladder is of tolerances: the slope is its tolerance proportionality, not an order
            order, local, note = None, [], adaptive_note(runs, fit)
            within = {k: StepWithin(None, w.wall_time, w.how, rtol=w.dt) for k, w in within.items()}
        methods[name] = MethodResult(name=name, engine=runner.engine,
                                     expected_order=runner.order_for(scenario.torque, scenario.model)[0],
                                     runs=runs, observed_order=order, order_note=note,
                                     local_orders=local, within=within)
        if res.series is not None:
            series[name] = res.series
    reference_error = next((res.reference_error for res in results if res.reference_error), None)
    if reference_error:
        checks = [Check("reference", False, note=f"the {scenario.reference} reference could not be computed: "
                                                 f"{reference_error}")]
    else:
        checks = None
    comparisons = resolve_comparisons(scenario, [c for res in results for c in res.comparisons])
    over_budget = {m: (left, why) for m, (_, left, why) in (planned or {}).items() if left and m not in broken}
    if checks is None:
        checks = study_checks(scenario, methods, scenario.checks, quick, comparisons)
        if _wide_orders(scenario, methods, checks, floor):
            checks = study_checks(scenario, methods, scenario.checks, quick, comparisons)
        checks = _budget_undecided(checks, over_budget)
    reference_check = next((res.reference_check for res in results if res.reference_check), None)
    used = reference_check["used"] if reference_check else scenario.reference
    reasons = [] if reference_error else qualify(scenario, methods, checks, reference=used,
                                                 reference_check=reference_check, comparisons=comparisons,
                                                 hint=lambda: _steady_hint(scenario))
    answer = your_step_answer(scenario, steps, methods, over_budget)
    for m in methods.values():
        m.verdict = verdict(m.name, checks)
        m.consistent, m.accurate = consistency(m.name, checks), accuracy(m, answer, scenario.checks.get("tolerance"))
    return StudyResult(scenario=scenario, steps=list(steps), methods=methods, checks=checks, order_floor=floor,
                       quick=quick, series=series, comparisons=comparisons, reference_check=reference_check,
                       inconclusive=reasons, not_run={**{m: why for m, why in not_run(scenario).items()
                                                         if m not in methods and _offered(RUNNERS[m])}, **broken},
                       over_budget=over_budget, your_step=answer, flips=_flips(results), precession=_cone(results),
                       advice=[] if reference_error else advice(scenario, methods),
                       built=_built(results), finer=dict(finer or {}))


def _built(results) -> dict:
    """The study's ``built`` (:attr:`StudyResult.built`) from its methods' runs."""
    said = [(RUNNERS[res.method].engine, res.built) for res in results if res.built]
    return {"body": said[0][1]["body"], "engines": {e: b["engine"] for e, b in said}} if said else {}


def _cone(results) -> dict | None:
    """The study's ``precession`` (:attr:`StudyResult.precession`): how it is measured, and the reference's own."""
    reference = next((res.reference_precession for res in results if res.reference_precession), None)
    return None if reference is None else {"how": PRECESSION_HOW, "reference": reference}


def _flips(results) -> dict | None:
    """The study's ``flips`` (:attr:`StudyResult.flips`): how they are measured, and the reference's own."""
    reference = next((res.reference_flips for res in results if res.reference_flips), None)
    return None if reference is None else {"how": FLIPS_HOW, "reference": reference}


def _budget_undecided(checks: list, over_budget: dict) -> list:
    """``checks`` without the order checks that the steps run could not decide where a step budget left out the
    finer ones (:func:`method_steps`): the study chose not to run the steps that would decide, so it claims nothing
    (the method is reported without that check, as a method it cannot run is); so is one that measured no order at
    all there, failed or not (issue 63: Drake's RK3 on a fast rod, 1.9 rad off at 1/100 s and 3.0e-5 at 1/4096 s, its
    finer steps over the budget, FAILED "no asymptotic range"). What was left undecided is said with the steps left
    out (``over_budget``, updated in place). An order measured wrong at the steps run stays."""
    kept = []
    for c in checks:
        if c.kind == "order" and (c.inconclusive or (c.failed and c.value is None)) and c.method in over_budget:
            left, why = over_budget[c.method]
            over_budget[c.method] = (left, f"{why}; its order is not measured at the steps run ({c.note})")
            continue
        kept.append(c)
    return kept


def _steady_hint(scenario: Scenario) -> str:
    """Why a scenario's motion is steady, from its body and state: at rest, isotropic, or turning about a principal
    axis with no torque (a uniform rotation); '' when none of these."""
    from .context import run_context

    ctx = run_context(scenario)
    w = np.asarray(ctx.omega0, dtype=float)
    if not np.any(w) and ctx.torque is None:
        return "the body is at rest and stays so"
    moments = np.linalg.eigvalsh(ctx.inertia)
    if ctx.torque is None and moments[-1] - moments[0] <= 1e-12 * moments[-1]:
        return "the body is isotropic: it turns uniformly about its initial rate"
    Iw = ctx.inertia @ w
    if ctx.torque is None and np.linalg.norm(np.cross(w, Iw)) <= 1e-12 * np.linalg.norm(w) * np.linalg.norm(Iw):
        return "the body turns about a principal axis: a uniform rotation"
    return ""


def throughput_rows(studies) -> list[dict]:
    """Best steps per second of every method in every study (``xcheck.bench/1`` rows, batch 1)."""
    rows = []
    for st in studies:
        for name, m in st.methods.items():
            rates = [r.steps_per_second for r in m.runs if r.steps_per_second]
            if rates:
                rows.append({"engine": m.engine, "method": name, "scenario": st.name, "batch": 1,
                             "steps_per_second": max(rates)})
    return rows
