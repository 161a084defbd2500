"""xcheck inside other people's pytest suites (issue 13): scenario files as tests.

Installed with xcheck (entry point ``pytest11``) and inactive until a file matches: every ``xcheck_*.toml``
and every ``xcheck_*.xml`` (an MJCF model alone: the scenario ``xcheck init`` would write for it)
(ini option ``xcheck_files``: file-name patterns, or patterns of paths relative to the root directory such as
``models/scenarios/*.toml``) is a scenario file, collected as ``<file>::<method>::<check>`` test items (each
check the study makes: ``runs``, ``order``, ``final-error``, ``invariants``, ``agreement``,
``expected-failure``), so that a failure names the method and the check and ``-k`` selects. A check the study
cannot decide (INCONCLUSIVE: no asymptotic range at its steps, a suspect or uncertain reference, a vacuous study;
xcheck's exit code 4) is a skipped item whose reason says why. The study runs
once per file, in this process, when its first item runs; its items share it (with pytest-xdist, use
``--dist loadfile`` so that one worker runs a file's items). Where ``-k`` (or ``-m``, or naming items) leaves out some
of a file's methods, the study runs the methods of its selected items and every method of xcheck's own (which the
engines are compared with, and which are fast): an engine's method nobody asked about is not run. Its judgement of
the study as a whole (a suspect reference, a vacuous study) is then made from the methods it ran.

Options: ``--xcheck-quick`` (or ini ``xcheck_quick = true``) runs the scenarios' quick steps; ``--xcheck-report
DIR`` writes the full cross-check report of the studies run (with xdist, one report per worker). A scenario
file that does not parse is one failing item with the CLI's message.

This module imports only pytest at start-up: every pytest run in an environment with xcheck loads it.
"""

from __future__ import annotations

import fnmatch
from pathlib import Path

import pytest

_STUDIES: list = []  # the studies run in this process, for --xcheck-report


def pytest_addoption(parser):
    group = parser.getgroup("xcheck", "xcheck scenario files")
    group.addoption("--xcheck-quick", action="store_true", default=False,
                    help="run the scenario files' quick steps (a fast look)")
    group.addoption("--xcheck-report", metavar="DIR", default=None,
                    help="write the cross-check report of the scenario files run into DIR")
    parser.addini("xcheck_files", type="args", default=["xcheck_*.toml", "xcheck_*.xml"],
                  help="scenario files collected as tests: file-name or root-relative path patterns")
    parser.addini("xcheck_quick", type="bool", default=False, help="like --xcheck-quick")


def pytest_configure(config):
    """``--xcheck-report`` is checked before any test runs (a folder that cannot be written is a usage error, not
    an internal error after the last test)."""
    out = config.getoption("xcheck_report", None)
    if out is not None:
        from .base.files import OutputPathError, check_output_dir

        try:
            check_output_dir(out, "--xcheck-report")
        except OutputPathError as exc:
            raise pytest.UsageError(str(exc)) from None
    config._xcheck_names = {}  # scenario name -> the file that has it


def _quick(config) -> bool:
    return bool(config.getoption("xcheck_quick") or config.getini("xcheck_quick"))


def pytest_collect_file(file_path: Path, parent):
    if file_path.suffix not in (".toml", ".xml"):  # a scenario file, or an MJCF model alone
        return None
    patterns = parent.config.getini("xcheck_files")
    try:
        relative = file_path.relative_to(parent.config.rootpath).as_posix()
    except ValueError:
        relative = file_path.as_posix()
    if any(fnmatch.fnmatch(file_path.name, p) or fnmatch.fnmatch(relative, p) for p in patterns):
        return ScenarioFile.from_parent(parent, path=file_path)
    return None


class XcheckFailure(Exception):
    """A check that failed; the message is the whole report (no traceback)."""


class ScenarioFile(pytest.File):
    """One scenario file: its methods, each with its checks."""

    def collect(self):
        import warnings

        from .scenario import load_scenario
        from .study import default_methods, planned_checks

        warnings.filterwarnings("ignore", category=UserWarning, module=r"xcheck\.models")
        try:
            if self.path.suffix.lower() == ".xml":  # a model alone: its keyframe is MuJoCo's to read
                from .scenario import scenario_from_model

                self.scenario = scenario_from_model(self.path)
            else:
                self.scenario = load_scenario(self.path, check_model=False)  # MuJoCo loads when the study runs
        except ValueError as exc:  # ScenarioError, an MJCF model's ModelError: the CLI's refusal, as one failing item
            yield BrokenScenario.from_parent(self, name="scenario", message=str(exc))
            return
        except Exception as exc:  # noqa: BLE001 - one broken file must not abort the collection of the others
            yield BrokenScenario.from_parent(self, name="scenario", message=f"{self.path}: xcheck could not read it "
                                             f"({type(exc).__name__}: {exc}); this is a bug in xcheck, please report it")
            return
        self._study = None
        names = getattr(self.config, "_xcheck_names", {})
        other = names.setdefault(self.scenario.name, self.path)
        if other != self.path and self.config.getoption("xcheck_report") is not None:
            # their sections and figures in the report would be written over each other
            yield BrokenScenario.from_parent(self, name="scenario", message=(
                f"{self.path}: the scenario name {self.scenario.name!r} is also {other}'s; --xcheck-report needs "
                "each scenario file to have its own name"))
            return
        methods = default_methods(self.scenario)
        planned = planned_checks(self.scenario, methods, quick=_quick(self.config))
        for method in [*methods, *(c.name for c in self.scenario.trajectories)]:  # methods, then trajectory files
            kinds = [k for m, k in planned if m == method]
            yield MethodNode.from_parent(self, name=method, kinds=kinds)

    def study(self):
        """The scenario's study, run once (the first item to ask runs it; an error is kept and raised again)."""
        if self._study is None:
            from .assembly import check_scenario_model
            from .study import run_study

            try:
                check_scenario_model(self.scenario)
                # a run is timed again only for --xcheck-report's figures (the checks read no wall time)
                st = run_study(self.scenario, methods=self._methods_to_run(), quick=_quick(self.config), workers=1,
                               timing=self.config.getoption("xcheck_report") is not None)
                _STUDIES.append(st)
                self._study = st
            except Exception as exc:  # e.g. a reference over budget: every item says so
                self._study = exc
        if isinstance(self._study, Exception):
            raise XcheckFailure(f"{self.scenario.name}: the study could not run: {self._study}")
        return self._study


    def _methods_to_run(self) -> list[str] | None:
        """The methods this file's study runs: None (all of the scenario's) where every method has a selected item;
        else the selected items' methods and all of xcheck's own, in the scenario's order (see the module
        docstring). The selection is the session's items after ``-k``, ``-m`` and named items took theirs out."""
        from .runners import RUNNERS
        from .study import default_methods

        methods = default_methods(self.scenario)
        selected = {item.parent.name for item in self.session.items
                    if isinstance(item, CheckItem) and item.parent.parent is self}
        if selected.issuperset(methods):
            return None
        return [m for m in methods if m in selected or RUNNERS[m].engine == "xcheck"]


class MethodNode(pytest.Collector):
    def __init__(self, *, kinds, **kwargs):
        super().__init__(**kwargs)
        self.kinds = kinds

    def collect(self):
        for kind in self.kinds:
            yield CheckItem.from_parent(self, name=kind)


class _Item(pytest.Item):
    def repr_failure(self, excinfo, style=None):
        if isinstance(excinfo.value, XcheckFailure):
            return str(excinfo.value)
        return super().repr_failure(excinfo, style=style)


class CheckItem(_Item):
    """One check of one method of a scenario file."""

    def runtest(self):
        from .testing import check_outcome

        st = self.parent.parent.study()
        status, message = check_outcome(st, self.parent.name, self.name)
        if status == "inconclusive":  # the study cannot decide this check: said, not failed (xcheck's exit code 4)
            pytest.skip(message)
        if status == "known":  # a known finding of the engine's explains it: an expected failure, named
            pytest.xfail(message)
        if status == "fail":
            raise XcheckFailure(message)

    def reportinfo(self):
        return self.path, None, f"{self.parent.parent.scenario.name}: {self.parent.name} {self.name}"


class BrokenScenario(_Item):
    """A scenario file that cannot be read: one failing item with the message the CLI gives."""

    def __init__(self, *, message, **kwargs):
        super().__init__(**kwargs)
        self.message = message

    def runtest(self):
        raise XcheckFailure(self.message)

    def reportinfo(self):
        return self.path, None, f"{self.path.name}: cannot be read"


def pytest_sessionfinish(session, exitstatus):
    out = session.config.getoption("xcheck_report")
    if not out or not _STUDIES:
        return
    from .report.render import write_report

    folder = write_report(list(_STUDIES), out, quick=_quick(session.config))
    session.config._xcheck_report = folder


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    folder = getattr(config, "_xcheck_report", None)
    if folder is not None:
        terminalreporter.write_line(f"xcheck report: {folder}/index.html")
