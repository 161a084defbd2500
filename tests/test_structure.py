"""The house's rules, checked on the source: no import cycles among xcheck's modules (counting imports inside
functions too), and a core that imports neither MuJoCo nor matplotlib (the engines, CLI and reports sit at
the edge)."""

import ast
from functools import lru_cache
from pathlib import Path

import pytest

import xcheck

PACKAGE = Path(xcheck.__file__).resolve().parent
#: The core: mathematics, integrators, references, metrics, fields (docs/architecture.md).
CORE = ["base", "rotations", "seeds", "body", "trajectory", "fields", "integrators", "reference", "elliptic", "guard",
        "defaults", "metrics", "invariants", "motion",
        "_jit", "_prebuilt", "paths", "results", "determination.methods", "determination.seed002", "league.boxes", "scoring.earth"]


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@lru_cache(maxsize=None)
def _tree(path: Path, stamp: int) -> ast.Module:
    """``path`` parsed, once per file and version (``stamp``, its modification time): the rules below read the
    package's 200 files again and again, and parsing them was most of this file's 20 s."""
    return ast.parse(path.read_text())


def imports(path: Path, modules=()) -> set[str]:
    """Every module this file imports, anywhere in it, as names relative to the package ('' is xcheck itself).
    ``from .pkg import name`` counts as importing ``pkg.name`` when that is one of ``modules``, else ``pkg``."""
    here = module_name(path).split(".") if module_name(path) else []
    package = here if path.name == "__init__.py" else here[:-1]

    def rel(name):
        return name.removeprefix("xcheck.") if name.startswith("xcheck.") else ("" if name == "xcheck" else name)

    out = set()
    for node in ast.walk(_tree(path, path.stat().st_mtime_ns)):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = rel(node.module)
            for a in node.names:
                full = f"{target}.{a.name}".lstrip(".")
                out.add(full if full in modules else target)
        elif isinstance(node, ast.Import):
            out.update(rel(a.name) for a in node.names)
    return out


def graph():
    modules = {module_name(p): p for p in PACKAGE.rglob("*.py") if "bundled" not in p.parts}
    return {m: sorted(i for i in imports(p, modules) if i in modules and i != m) for m, p in modules.items()}, modules


def test_no_import_cycles():
    edges, _ = graph()
    state, stack, cycles = {}, [], []

    def visit(m):
        state[m] = "open"
        stack.append(m)
        for n in edges[m]:
            if state.get(n) == "open":
                cycles.append(stack[stack.index(n):] + [n])
            elif n not in state:
                visit(n)
        stack.pop()
        state[m] = "done"

    for m in edges:
        if m not in state:
            visit(m)
    assert not cycles, " ; ".join(" -> ".join(c) for c in cycles)


def test_the_cycle_finder_finds_a_cycle(tmp_path):
    """The check above can fail: a two-module cycle written out is found by the same parser."""
    (tmp_path / "a.py").write_text("from .b import x\n")
    (tmp_path / "b.py").write_text("def f():\n    from .a import y\n")
    global PACKAGE
    saved, PACKAGE = PACKAGE, tmp_path
    try:
        edges, _ = graph()
    finally:
        PACKAGE = saved
    assert edges == {"a": ["b"], "b": ["a"]}


@pytest.mark.parametrize("room", CORE)
def test_core_imports_no_engine_and_no_plotting(room):
    _, modules = graph()
    files = [p for m, p in modules.items() if m == room or m.startswith(room + ".")]
    assert files
    for path in files:
        bad = {i for i in imports(path) if i.split(".")[0] in ("mujoco", "matplotlib")}
        assert not bad, f"{path.relative_to(PACKAGE)} imports {sorted(bad)}"


def test_every_subpackage_is_in_the_wheel():
    """A folder of xcheck missing from pyproject's ``packages`` works in a checkout and is absent from an
    installed copy (README line 1 installs one)."""
    import tomllib

    listed = set(tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {"xcheck." + ".".join(p.parent.relative_to(PACKAGE).parts) if p.parent != PACKAGE else "xcheck"
             for p in PACKAGE.rglob("__init__.py") if "bundled" not in p.parts}
    assert found <= listed, sorted(found - listed)


ARCHITECTURE = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"
_FILES = (".py", ".sqlite", ".json", ".toml", ".csv", ".md", ".png", ".xml", ".html", ".jsonl", ".txt")


def _package_modules() -> list[str]:
    return sorted(p.relative_to(PACKAGE).as_posix() for p in PACKAGE.rglob("*.py") if "bundled" not in p.parts)


def test_the_architecture_notes_name_every_module():
    """Issue 25: docs/architecture.md describes the house as built: every module of the package is named in it."""
    doc = ARCHITECTURE.read_text(encoding="utf-8")
    unnamed = [m for m in _package_modules() if m != "__init__.py" and not m.endswith("/__init__.py")
               and m.rsplit("/", 1)[-1] not in doc]
    assert not unnamed, f"docs/architecture.md does not name {unnamed}"


#: Journals of earlier sessions: they name the house as it was when each entry was written (each says so at its top).
HISTORY_PAGES = ("decisions.md", "performance.md")


@pytest.mark.parametrize("page", sorted(p.name for p in ARCHITECTURE.parent.glob("*.md") if p.name not in HISTORY_PAGES)
                         + ["README.md"])
def test_the_docs_name_nothing_that_does_not_exist(page):
    """Issues 25 and 38: a file name (``study.py``) in a page of the docs is a file of the project, and a dotted name
    in backticks that starts with a module of the package (``study.measure_run``, ``xcheck.base.pool.stop_pool``) is
    an attribute it has."""
    import importlib
    import re

    root = PACKAGE.parent
    doc = (root / page if page == "README.md" else ARCHITECTURE.parent / page).read_text(encoding="utf-8")
    files = {p.name for p in root.rglob("*.py") if ".venv" not in p.parts and "build" not in p.parts}
    gone = sorted(n for n in set(re.findall(r"\b[\w/]+\.py\b", doc)) if n.rsplit("/", 1)[-1] not in files)
    assert not gone, f"{page} names files that do not exist: {gone}"
    modules = {m.removesuffix(".py").removesuffix("/__init__").replace("/", ".") for m in _package_modules()}
    missing = []
    for ref in sorted(set(re.findall(r"`((?:xcheck\.)?[a-z_]+(?:\.[A-Za-z_]\w*)+)", doc))):
        if ref.endswith(_FILES):
            continue
        parts = ref.removeprefix("xcheck.").split(".")
        for k in range(len(parts), 0, -1):  # the longest prefix that is a module, then its attributes
            if ".".join(parts[:k]) in modules:
                obj = importlib.import_module("xcheck." + ".".join(parts[:k]))
                for name in parts[k:]:
                    if not hasattr(obj, name):
                        missing.append(ref)
                        break
                    obj = getattr(obj, name)
                break
    assert not missing, f"{page} names what the code does not have: {missing}"


COLLECT_WITHOUT_MUJOCO = """
import sys
import pytest
import xcheck.scenario as S
S.load_scenario(S.SCENARIO_DIR / "gyroscope-nonsingular.toml", check_model=False)
after_reading = "mujoco" in sys.modules
code = pytest.main(["--collect-only", "-q", "-p", "no:cacheprovider", str(S.SCENARIO_DIR / "tumbler-intermediate-axis.toml")])
print(after_reading, "mujoco" in sys.modules, "matplotlib" in sys.modules, int(code))
"""


def test_reading_a_scenario_and_collecting_its_items_import_no_mujoco(tmp_path):
    """Issue 25: reading a scenario (without its model check) and collecting the pytest items of a scenario file
    load neither MuJoCo nor matplotlib; the model is loaded, and checked, when the study runs."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", COLLECT_WITHOUT_MUJOCO], capture_output=True, text=True, timeout=120,
                          cwd=PACKAGE.parent)
    assert proc.stdout.split()[-4:] == ["False", "False", "False", "0"], proc.stdout[-2000:] + proc.stderr[-2000:]


def _in(room: str, rooms) -> bool:
    return any(room == r or room.startswith(r + ".") for r in rooms)


def test_the_core_imports_only_the_core():
    """No arrow runs against the layers: a core module imports only core modules of xcheck (the engines, the
    study, the report and the command line sit above it). ``versions`` reads the engines' records, so it sits above
    the core, beside the scenario and the runners."""
    edges, _ = graph()
    upward = {(m, n) for m, targets in edges.items() if _in(m, CORE) for n in targets if n and not _in(n, CORE)}
    assert not upward, sorted(upward)


def test_the_layer_check_sees_an_upward_arrow():
    """The check above can fail: a core module importing the study is found."""
    edges = {"rotations": ["study"], "study": ["rotations"]}
    upward = {(m, n) for m, targets in edges.items() if _in(m, CORE) for n in targets if n and not _in(n, CORE)}
    assert upward == {("rotations", "study")}


def test_every_refusal_is_a_user_error_and_exits_2_by_its_type(capsys, monkeypatch):
    """Issue 38: one base class, not a table of module names: each refusal class of the package derives from
    base.errors.UserError, and the command line exits 2 on any subclass, even one it has never heard of."""
    import argparse
    import importlib

    from xcheck import cli
    from xcheck.base.errors import UserError

    refusals = {"scenario": "ScenarioError", "models": "ModelError", "base.files": "OutputPathError",
                "history.store": "HistoryError", "determination.methods": "DeterminationError",
                "history.matrix": "MatrixError", "sweep.spec": "SweepError", "cli": "UsageError"}
    for module, name in refusals.items():
        assert issubclass(getattr(importlib.import_module(f"xcheck.{module}"), name), UserError), name

    class NewRefusal(UserError):
        pass

    def command(*, ctx):
        raise NewRefusal("thing.toml: [new] key: expected a number")

    monkeypatch.setattr("xcheck.commands.studies.list_all", command)
    assert cli._run(argparse.Namespace(command="list")) == 2
    assert capsys.readouterr().err == "xcheck: error: thing.toml: [new] key: expected a number\n"


#: The layers of the house, bottom to top (docs/architecture.md): a module may import its own layer and those below,
#: never one above. A room is a module or a package; the longest name that matches places a module.
LAYERS = (
    ("base", "paths", "_jit", "_prebuilt", ""),  # what everyone uses ("" is xcheck itself: its version)
    tuple(CORE),  # the mathematics: rotations, integrators, references, fields, metrics
    ("models", "engines", "versions", "torque_terms", "scenario", "model_scenario", "assembly", "runners",
     "determination.sensors", "scoring"),  # bodies, engines, scenarios and what they assemble; files scored
    ("study", "determination", "sweep", "league.run", "league.releases", "history.store", "history.matrix",
     "history", "bench"),  # studies and their runs
    ("report", "league", "league.precision", "history.nightly", "pytest_plugin", "testing"),  # what is written
    ("commands",),  # the workflow layer: one function per command
    ("cli", "__main__"),  # argparse, signals, exit codes
)


def _layer(module: str, layers=LAYERS) -> int | None:
    best = None
    for k, rooms in enumerate(layers):
        for room in rooms:
            if module == room or (room and module.startswith(room + ".")):
                if best is None or len(room) > best[1]:
                    best = (k, len(room))
    return None if best is None else best[0]


def _against_the_layers(edges, layers=LAYERS) -> list:
    return sorted((m, n) for m, targets in edges.items() for n in targets
                  if _layer(n, layers) > _layer(m, layers))


def test_every_module_has_a_layer():
    edges, _ = graph()
    assert not [m for m in edges if _layer(m) is None]


def test_no_import_runs_against_the_layers():
    """Issue 38: anywhere in the package, not only the core — a helper sits below its users."""
    edges, _ = graph()
    assert not _against_the_layers(edges)


def test_the_layer_rule_sees_an_arrow_against_the_layers():
    edges = {"report.render": ["base.files"], "base.files": ["report.render"]}
    assert _against_the_layers(edges) == [("base.files", "report.render")]


def test_modules_stay_readable():
    """Issue 38: no module over 800 lines (integrators/_kernels.py had 1 380, scenario.py 844); cli.py, argparse,
    signals and exit codes, at most 350 lines and 8 of the package's modules."""
    sizes = {p.relative_to(PACKAGE).as_posix(): len(p.read_text().splitlines()) for p in PACKAGE.rglob("*.py")
             if "bundled" not in p.parts}
    long = {m: n for m, n in sizes.items() if n > 800}
    assert not long, long
    assert sizes["cli.py"] <= 350
    edges, _ = graph()
    assert len([n for n in edges["cli"] if n]) <= 8, edges["cli"]


def test_the_architecture_notes_stay_a_description():
    """Issue 38: docs/architecture.md describes the house (at most 300 lines: the layers, the data flow, the rooms,
    how to add); the journal of decisions and measurements lives in docs/decisions.md and docs/performance.md."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 300
    assert all(f"## {h}" in text for h in ("The layers", "How data flows", "Rooms", "How to add"))


def test_the_quick_inner_loop_names_files_that_exist_and_is_in_the_readme():
    """``pytest -m core`` (tests/conftest.py CORE) selects test files that exist, each with tests; the marker is
    registered and the README's development section names the command (issue 61)."""
    import tomllib

    from conftest import CORE

    here = Path(__file__).parent
    missing = [name for name in CORE if not (here / name).is_file()]
    assert not missing, f"CORE names test files that do not exist: {missing}"
    empty = [name for name in CORE if "\ndef test_" not in (here / name).read_text()]
    assert not empty, f"CORE names files without tests: {empty}"
    markers = tomllib.loads((here.parent / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]["markers"]
    assert any(m.startswith("core:") for m in markers)
    assert "pytest -q -n 2 --dist loadfile -m core" in (here.parent / "README.md").read_text()
