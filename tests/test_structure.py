"""The house's rules, checked on the source: no import cycles among xcheck's modules (counting imports inside
functions too), and a core that imports neither MuJoCo nor matplotlib (the engines, CLI and reports sit at
the edge)."""

import ast
from pathlib import Path

import pytest

import xcheck

PACKAGE = Path(xcheck.__file__).resolve().parent
#: The core: mathematics, integrators, references, metrics, fields (docs/architecture.md).
CORE = ["rotations", "seeds", "body", "trajectory", "fields", "integrators", "reference", "metrics", "versions",
        "_jit", "determination", "seed002"]


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path, modules=()) -> set[str]:
    """Every module this file imports, anywhere in it, as names relative to the package ('' is xcheck itself).
    ``from .pkg import name`` counts as importing ``pkg.name`` when that is one of ``modules``, else ``pkg``."""
    here = module_name(path).split(".") if module_name(path) else []
    package = here if path.name == "__init__.py" else here[:-1]

    def rel(name):
        return name.removeprefix("xcheck.") if name.startswith("xcheck.") else ("" if name == "xcheck" else name)

    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
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
